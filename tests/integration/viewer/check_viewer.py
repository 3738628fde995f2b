#!/usr/bin/env python3
"""Checks a running fieldline-viewer against what viewer_publish_robot_state published."""
import base64
import http.client
import json
import os
import socket
import struct
import sys
import time

port = int(sys.argv[1])
published_path = sys.argv[2]
failures = []


def request(method, path, body=None):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
    conn.request(method, path, body=body)
    response = conn.getresponse()
    data = response.read()
    conn.close()
    return response.status, dict(response.getheaders()), data


def robot_state_of(state, robot_id):
    for robot in state["robots"]:
        if robot["id"] == robot_id:
            return robot["robot_state"]
    raise KeyError(f"robot {robot_id} missing from the state")


def compare(where, served, published):
    for key, value in published.items():
        if served.get(key) != value:
            failures.append(f"{where}: {key} is {served.get(key)!r}, published {value!r}")
    if served.get("robot_id") != 3:
        failures.append(f"{where}: header robot_id {served.get('robot_id')!r}, expected 3")


def web_socket_open():
    """A connected /ws socket after the RFC 6455 handshake, as a buffered reader."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=5)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    reader = sock.makefile("rb")
    status = reader.readline()
    if b" 101 " not in status:
        raise RuntimeError(f"WebSocket upgrade refused: {status!r}")
    while reader.readline() not in (b"\r\n", b""):
        pass
    return sock, reader


def web_socket_read(reader):
    """The next text message (server frames are unmasked and, here, never fragmented)."""
    first, second = reader.read(2)
    if first & 0x0F != 1:
        raise RuntimeError(f"expected a text frame, got opcode {first & 0x0F}")
    length = second & 0x7F
    if length == 126:
        length = struct.unpack(">H", reader.read(2))[0]
    elif length == 127:
        length = struct.unpack(">Q", reader.read(8))[0]
    return json.loads(reader.read(length))


# The publisher prints its values before it publishes; wait for them and for the viewer.
deadline = time.monotonic() + 15
published = None
state = None
while time.monotonic() < deadline:
    try:
        if published is None:
            with open(published_path) as f:
                line = f.readline()
            published = json.loads(line) if line.endswith("\n") else None
        status, _, body = request("GET", "/state.json")
        state = json.loads(body)
        if published is not None and robot_state_of(state, 3) is not None:
            break
    except (OSError, ValueError, KeyError):
        pass
    time.sleep(0.1)
if published is None or state is None or robot_state_of(state, 3) is None:
    print("FAIL: no ROBOT_STATE for robot 3 reached the viewer within 15 s")
    sys.exit(1)

compare("state.json", robot_state_of(state, 3), published)
for robot in state["robots"]:
    if robot["id"] != 3 and robot["robot_state"] is not None:
        failures.append(f"robot {robot['id']} shows a ROBOT_STATE, only robot 3's was published")
if [r["id"] for r in state["robots"]] != [1, 2, 3, 4, 5, 6]:
    failures.append(f"robots {[r['id'] for r in state['robots']]}, expected 1..6")

# Ten clients at once, as in issue 14: each gets pushed states, two in a row each.
clients = [web_socket_open() for _ in range(10)]
for round_ in range(2):
    for i, (_, reader) in enumerate(clients):
        compare(f"WebSocket client {i + 1}", robot_state_of(web_socket_read(reader), 3), published)
for sock, _ in clients:
    sock.close()

for method in ("POST", "PUT", "DELETE", "PATCH", "HEAD", "OPTIONS"):
    status, headers, _ = request(method, "/state.json", body=b"x")
    if status != 405:
        failures.append(f"{method} /state.json: {status}, expected 405")
    elif "GET" not in headers.get("Allow", ""):
        failures.append(f"{method}: 405 without an Allow: GET header")
status, _, _ = request("GET", "/../../etc/passwd")
if status != 404:
    failures.append(f"GET /../../etc/passwd: {status}, expected 404")
# The camera view: no camera publishes here, so robot 3's document has no frame yet; a missing or
# bad robot number is 400, and POST is refused like everywhere.
status, _, body = request("GET", "/camera.json?robot=3")
if status != 200 or json.loads(body) != {"robot": 3, "frame": None, "lines": None, "ball": None}:
    failures.append(f"GET /camera.json?robot=3: {status} {body[:200]!r}")
for path in ("/camera.json", "/camera.json?robot=", "/camera.json?robot=x", "/camera.json?robot=0",
             "/camera.json?robot=123", "/camera.json?id=3"):
    status, _, _ = request("GET", path)
    if status != 400:
        failures.append(f"GET {path}: {status}, expected 400")
status, _, _ = request("POST", "/camera.json?robot=3", body=b"x")
if status != 405:
    failures.append(f"POST /camera.json: {status}, expected 405")
for path, needle in (("/", b"<canvas"), ("/viewer.js", b"WebSocket"), ("/field.json", b"segments")):
    status, _, body = request("GET", path)
    if status != 200 or needle not in body:
        failures.append(f"GET {path}: {status}, {len(body)} bytes without {needle!r}")

for f in failures:
    print("FAIL:", f)
if not failures:
    print(f"ok: robot 3 x={published['x']} served unchanged over state.json and to 10 /ws "
          "clients; "
          "POST/PUT/DELETE/PATCH/HEAD/OPTIONS refused with 405")
sys.exit(1 if failures else 0)
