#!/usr/bin/env python3
"""Opens the viewer page in headless chromium and reads what the page drew (its #drawn element)
over the DevTools protocol until six robots are drawn, then compares robot 3's drawn state with the
ROBOT_STATE messages fieldline-bus-dump heard on robot 3's bus. Then checks the camera view of
the selected robot (1): a decoded JPEG of the camera's size, and as many line-point marks as the
VISION_LINES robot 1's tracker published for that frame (same utime and seq). Optionally saves a
screenshot.

  check_browser.py CHROMIUM VIEWER_PORT ROBOT3_JSONL LINES1_JSONL WORK_DIR [SCREENSHOT.png]
"""
import base64
import json
import os
import socket
import struct
import subprocess
import sys
import time
import urllib.request

chromium, port, robot3_path, lines1_path, work_dir = sys.argv[1:6]
screenshot = sys.argv[6] if len(sys.argv) > 6 else ""
FRAME_US = 50_000  # the viewer's 20 Hz WebSocket period
ROBOT = 3
DEVTOOLS_PORT = 9333


class DevTools:
    """A minimal DevTools-protocol client: one page target, commands answered in order."""

    def __init__(self, ws_url):
        rest = ws_url.split("://", 1)[1]
        hostport, path = rest.split("/", 1)
        host, ws_port = hostport.split(":")
        self.sock = socket.create_connection((host, int(ws_port)), timeout=10)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET /{path} HTTP/1.1\r\nHost: {hostport}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n").encode())
        self.reader = self.sock.makefile("rb")
        status = self.reader.readline()
        if b" 101 " not in status:
            raise RuntimeError(f"DevTools refused the WebSocket: {status!r}")
        while self.reader.readline() not in (b"\r\n", b""):
            pass
        self.next_id = 0

    def _send(self, text):
        data = text.encode()
        mask = os.urandom(4)
        header = bytes([0x81])
        if len(data) < 126:
            header += bytes([0x80 | len(data)])
        elif len(data) < 65536:
            header += bytes([0x80 | 126]) + struct.pack(">H", len(data))
        else:
            header += bytes([0x80 | 127]) + struct.pack(">Q", len(data))
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(data))
        self.sock.sendall(header + mask + masked)

    def _read(self):
        message = b""
        while True:
            first, second = self.reader.read(2)
            length = second & 0x7F
            if length == 126:
                length = struct.unpack(">H", self.reader.read(2))[0]
            elif length == 127:
                length = struct.unpack(">Q", self.reader.read(8))[0]
            message += self.reader.read(length)
            if first & 0x80:  # FIN
                return json.loads(message)

    def call(self, method, **params):
        self.next_id += 1
        self._send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            reply = self._read()
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    def evaluate(self, expression):
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return result["result"].get("value")


def published(path=robot3_path):
    messages = []
    with open(path) as f:
        for line in f:
            try:
                messages.append(json.loads(line))
            except json.JSONDecodeError:
                pass  # the line being written
    return messages


# The viewer starts with the team: chromium opened before its server listened showed an error page
# under the viewer's address and never loaded the viewer (one run in six or seven).
deadline = time.monotonic() + 30
while True:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2):
            break
    except OSError:
        if time.monotonic() > deadline:
            sys.exit(f"FAIL: the viewer did not answer on port {port} within 30 s")
        time.sleep(0.2)

browser = subprocess.Popen(
    [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
     f"--remote-debugging-port={DEVTOOLS_PORT}", f"--user-data-dir={work_dir}/profile",
     "--window-size=1400,800", f"http://127.0.0.1:{port}/"],
    stdout=subprocess.DEVNULL, stderr=open(f"{work_dir}/chromium.log", "w"),
    # Its scratch folders in the test's own folder: killed at the end, chromium leaves them behind.
    env=dict(os.environ, TMPDIR=work_dir))
try:
    devtools = None
    deadline = time.monotonic() + 20
    while devtools is None and time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{DEVTOOLS_PORT}/json", timeout=2) as r:
                # The viewer's own page (chromium may list a blank one first).
                pages = [t for t in json.load(r) if t.get("type") == "page" and
                         t.get("url", "").startswith(f"http://127.0.0.1:{port}/")]
            if pages:
                devtools = DevTools(pages[0]["webSocketDebuggerUrl"])
            else:
                time.sleep(0.5)
        except OSError:
            time.sleep(0.5)
    if devtools is None:
        sys.exit("FAIL: chromium's DevTools endpoint did not come up")

    # Six robots drawn is required; six that localize (status tracking) is waited for as long as
    # the deadline allows, so that the check and the screenshot see the team at work.
    TRACKING = 2
    deadline = time.monotonic() + 60
    drawn = None
    ids = []
    tracking = []
    progress = time.monotonic()
    while time.monotonic() < deadline:
        if time.monotonic() > progress:
            print(f"waiting: robots drawn {ids}, tracking {tracking}", flush=True)
            progress += 5
        text = devtools.evaluate("document.getElementById('drawn').textContent")
        drawn = json.loads(text) if text else None
        robots = drawn["robots"] if drawn else []
        ids = sorted({r["id"] for r in robots})
        tracking = sorted({r["id"] for r in robots if r["status"] == TRACKING})
        if len(tracking) == 6:
            break
        time.sleep(0.5)
    connection = devtools.evaluate("document.getElementById('connection').textContent")
    print(f"page: {connection}; robots drawn {ids}, tracking {tracking}")
    if len(ids) != 6:
        sys.exit("FAIL: six robots were not drawn within 60 s")
    # The camera view of the selected robot (1, the page's default): a frame with line points.
    camera = None
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline:
        text = devtools.evaluate("document.getElementById('camera-drawn').textContent")
        camera = json.loads(text) if text else None
        if camera and camera["marks"] > 0:
            break
        time.sleep(0.5)
    camera_read_at = time.time()
    # How often the page's camera view changes (it polls every 200 ms): distinct frames in 3 s.
    camera_frames = set()
    for _ in range(10):
        text = devtools.evaluate("document.getElementById('camera-drawn').textContent")
        if text:
            camera_frames.add(json.loads(text)["utime"])
        time.sleep(0.3)
    # The drawn state and the bus dump up to it: read the page first, the dump a little later.
    drawn = json.loads(devtools.evaluate("document.getElementById('drawn').textContent"))
    if screenshot:
        time.sleep(1.0)  # a little more of the run on the picture
        shot = devtools.call("Page.captureScreenshot", format="png")
        with open(screenshot, "wb") as f:
            f.write(base64.b64decode(shot["data"]))
        print(f"screenshot: {screenshot}")
finally:
    browser.terminate()
    browser.wait()

# The dumps hold what they heard up to the document's time once they hold something heard after
# it (not after a fixed 0.5 s: a bus-dump of a loaded machine can be later than that; bounded).
dumps_deadline = time.monotonic() + 10
while time.monotonic() < dumps_deadline and not (
        any(m["receive_utime"] > drawn["utime"] for m in published()) and
        any(m["receive_utime"] > camera_read_at * 1e6 for m in published(lines1_path))):
    time.sleep(0.1)
failures = []
mine = [r for r in drawn["robots"] if r["id"] == ROBOT]
if len(mine) != 1:
    sys.exit(f"FAIL: robot {ROBOT} drawn {len(mine)} times")
mine = mine[0]
messages = published()
same = [m for m in messages if m["message"]["header"]["utime"] == mine["utime"]
        and m["message"]["header"]["seq"] == mine["seq"]]
if not same:
    failures.append(f"no ROBOT_STATE with utime {mine['utime']} seq {mine['seq']} was published "
                    f"({len(messages)} heard)")
else:
    msg = same[0]["message"]
    for key in ("x", "y", "phi", "status", "twin_ambiguous"):
        if msg[key] != mine[key]:
            failures.append(f"drawn {key} {mine[key]!r}, published {msg[key]!r}")
before = [m for m in messages if m["receive_utime"] <= drawn["utime"]]
if not before:
    failures.append("nothing published before the drawn document")
else:
    last = before[-1]["message"]["header"]["utime"]
    lag = last - mine["utime"]
    print(f"robot {ROBOT}: drawn utime {mine['utime']}, last published before the document "
          f"{last}: {lag / 1000:.1f} ms apart (one frame: {FRAME_US / 1000:.0f} ms)")
    # Only a drawn state older than the newest one heard before the document by more than a
    # period fails: bus-dump stamps a message when it reads it, so a dump descheduled at the
    # document's time counts the newest messages after it, and the drawn one looks newer (it
    # was published: it is in the dump above).
    if lag > FRAME_US:
        failures.append(f"the drawn state is {lag / 1000:.1f} ms behind the last published one")
print(f"robot {ROBOT} drawn at x {mine['x']:.3f} y {mine['y']:.3f} phi {mine['phi']:.3f} "
      f"status {mine['status']}; {len(messages)} ROBOT_STATE heard")

if not camera:
    failures.append("the camera view drew nothing within 15 s")
else:
    print(f"camera view: robot {camera['robot']}, frame utime {camera['utime']}, "
          f"{camera['image_width']}x{camera['image_height']} decoded from {camera['jpeg_bytes']} "
          f"bytes of JPEG, {camera['marks']} line-point marks, ball {camera['ball']}")
    if camera["robot"] != 1:
        failures.append(f"camera view of robot {camera['robot']}, robot 1 is selected")
    if not (camera["image_width"] == camera["width"] > 0 and
            camera["image_height"] == camera["height"] > 0 and camera["jpeg_bytes"] > 0):
        failures.append(f"camera image not drawn at its size: {camera}")
    if camera["marks"] == 0:
        failures.append("no line-point marks on the camera view")
    if camera["lines_utime"] != camera["utime"]:
        failures.append("the camera view's lines are not of the frame shown")
    lines = published(lines1_path)
    same = [m["message"] for m in lines
            if m["message"]["header"]["utime"] == camera["lines_utime"]
            and m["message"]["header"]["seq"] == camera["lines_seq"]]
    if not same:
        failures.append(f"no VISION_LINES with utime {camera['lines_utime']} seq "
                        f"{camera['lines_seq']} was published on robot 1's bus "
                        f"({len(lines)} heard)")
    elif same[0]["num_points"] != camera["marks"]:
        failures.append(f"{camera['marks']} marks drawn, the frame's VISION_LINES has "
                        f"{same[0]['num_points']} points")
    else:
        heard = [m["message"]["header"]["utime"] for m in lines
                 if m["receive_utime"] <= camera_read_at * 1e6]
        behind = (max(heard) - camera["utime"]) / 1000 if heard else float("nan")
        print(f"camera view: marks equal the frame's VISION_LINES num_points "
              f"({camera['marks']}); the frame shown was {behind:.0f} ms older than the newest "
              f"VISION_LINES heard when the page was read; {len(camera_frames)} distinct frames "
              f"drawn in 3 s")

for failure in failures:
    print("FAIL:", failure)
sys.exit(1 if failures else 0)
