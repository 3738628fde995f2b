#!/usr/bin/env python3
"""Opens fieldline-viewer --log's page in headless chromium, scrubs its timeline to a chosen time
(the slider, as a user drags it, with playback paused), and checks over the DevTools protocol:
  - the page drew every recorded robot, each exactly as the last ROBOT_STATE its recording holds
    with a log time at or before the playhead (utime, seq, x, y, phi, status);
  - the error-against-truth plot exists and has points for every robot;
then scrubs to a second time and checks the drawing follows. Optionally saves a screenshot.

  check_playback.py CHROMIUM VIEWER_PORT WORK_DIR SCREENSHOT|"" ROBOT1.jsonl [ROBOT2.jsonl ...]
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

chromium, port, work_dir, screenshot = sys.argv[1:5]
dumps = sys.argv[5:]
DEVTOOLS_PORT = 9334
# Playhead times, seconds from the recording's start; later by as much as the last robot's first
# ROBOT_STATE (+ 1 s) comes after the first of them: the team's own recording
# (fusion_team_rates_and_tracking's) starts its recorder before six robots start up, and a robot
# with no state yet is not drawn.
CHOSEN_S = (6.0, 9.5)


class DevTools:
    """A minimal DevTools-protocol client: one page target, commands answered in order."""

    def __init__(self, ws_url):
        rest = ws_url.split("://", 1)[1]
        hostport, path = rest.split("/", 1)
        host, ws_port = hostport.split(":")
        self.sock = socket.create_connection((host, int(ws_port)), timeout=20)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET /{path} HTTP/1.1\r\nHost: {hostport}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n").encode())
        self.reader = self.sock.makefile("rb")
        if b" 101 " not in self.reader.readline():
            raise RuntimeError("DevTools refused the WebSocket")
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
        self.sock.sendall(header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))

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
            if first & 0x80:
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
        return self.call("Runtime.evaluate", expression=expression,
                         returnByValue=True)["result"].get("value")


def logged_states(path):
    """(log_utime, message) of every ROBOT_STATE in a bus-dump of a recording, in log order."""
    with open(path) as f:
        return [(m["log_utime"], m["message"]) for m in map(json.loads, f)]


recorded = {}
for path in dumps:
    states = logged_states(path)
    if states:
        recorded[states[0][1]["header"]["robot_id"]] = states
if not recorded:
    sys.exit("FAIL: the recording holds no ROBOT_STATE")

browser = subprocess.Popen(
    [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
     f"--remote-debugging-port={DEVTOOLS_PORT}", f"--user-data-dir={work_dir}/profile",
     "--window-size=1400,900", f"http://127.0.0.1:{port}/"],
    stdout=subprocess.DEVNULL, stderr=open(f"{work_dir}/chromium.log", "w"),
    # Its scratch folders in the test's own folder: killed at the end, chromium leaves them behind.
    env=dict(os.environ, TMPDIR=work_dir))
try:
    devtools = None
    deadline = time.monotonic() + 30
    while devtools is None and time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{DEVTOOLS_PORT}/json", timeout=2) as r:
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

    # The page has loaded the recording and drawn its plots.
    plotted = None
    deadline = time.monotonic() + 40
    while time.monotonic() < deadline:
        text = devtools.evaluate("document.getElementById('plotted').textContent")
        if text:
            plotted = json.loads(text)
            break
        time.sleep(0.5)
    if not plotted or "load_error" in plotted:
        sys.exit(f"FAIL: the page did not plot the recording: {plotted}")
    error_points = {d["label"]: d["points"] for d in plotted.get("error", [])}
    print(f"error plot: {error_points}")
    failures = []
    for robot in recorded:
        if error_points.get(f"robot {robot}", 0) == 0:
            failures.append(f"the error plot has no point of robot {robot}")
    if not devtools.evaluate("!!document.getElementById('plot-error')"):
        failures.append("no error chart on the page")

    start = devtools.evaluate("window.fieldlineRecording.start_utime")
    all_up_s = (max(states[0][0] for states in recorded.values()) - start) / 1e6 + 1.0
    later = max(0.0, all_up_s - CHOSEN_S[0])
    for chosen in (round(c + later, 1) for c in CHOSEN_S):
        # Scrub as a user does: the slider moves, its input event asks the viewer for that time.
        devtools.evaluate(
            "(() => { const s = document.getElementById('scrub'); fetch('/playback.json?pause');"
            f" s.value = '{chosen}'; s.dispatchEvent(new Event('input'));"
            " s.dispatchEvent(new Event('change')); })()")
        want_utime = start + round(chosen * 1e6)
        drawn = None
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            text = devtools.evaluate("document.getElementById('drawn').textContent")
            doc = json.loads(text) if text else None
            if doc and doc.get("utime") == want_utime and len(doc["robots"]) == len(recorded):
                drawn = doc
                break
            time.sleep(0.3)
        if drawn is None:
            failures.append(f"t = {chosen} s: the page did not draw the team at the playhead "
                            f"(last: {text})")
            continue
        for d in drawn["robots"]:
            before = [m for t, m in recorded.get(d["id"], []) if t <= want_utime]
            if not before:
                failures.append(f"t = {chosen} s: robot {d['id']} drawn but nothing was logged "
                                f"before")
                continue
            m = before[-1]
            want = (m["header"]["utime"], m["header"]["seq"], m["x"], m["y"], m["phi"],
                    m["status"])
            got = (d["utime"], d["seq"], d["x"], d["y"], d["phi"], d["status"])
            verdict = "ok" if want == got else "DIFFERENT"
            print(f"t = {chosen} s: robot {d['id']} drawn at ({d['x']:.3f}, {d['y']:.3f}, "
                  f"{d['phi']:.3f}) seq {d['seq']}; logged last before: seq {want[1]}: {verdict}")
            if want != got:
                failures.append(f"t = {chosen} s: robot {d['id']}: drawn {got}, logged {want}")
    if screenshot:
        shot = devtools.call("Page.captureScreenshot", format="png")
        with open(screenshot, "wb") as f:
            f.write(base64.b64decode(shot["data"]))
        print(f"screenshot: {screenshot}")
    for f in failures:
        print(f"FAIL: {f}")
    sys.exit(1 if failures else 0)
finally:
    browser.terminate()
    try:
        browser.wait(timeout=10)
    except subprocess.TimeoutExpired:
        browser.kill()
