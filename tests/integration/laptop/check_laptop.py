#!/usr/bin/env python3
"""The laptop's side of laptop_test.sh: fieldline-viewer (on PORT, watching robots 1 and 2 over the
bridge) must show both robots' ROBOT_STATE, each robot's processes by their SERVICE_STATUS, the
robots seeing each other in TEAM_STATE, and robot 1's camera view from the reduced CAMERA_PREVIEW;
fieldline-bus-stats on the laptop (what lcm-spy would see) must hear no CAMERA_IMAGE at all.

Usage: check_laptop.py PORT BIN_DIR OUT_DIR"""
import http.client
import json
import subprocess
import sys
import time

port = int(sys.argv[1])
bin_dir = sys.argv[2]
out_dir = sys.argv[3]
ROBOTS = (1, 2)
PROCESSES = {"camera", "region_tracking", "feature_recognition", "fusion", "teamcomm",
             "motor_bridge", "pilot"}
failures = []


def get(path):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
    conn.request("GET", path)
    response = conn.getresponse()
    data = response.read()
    conn.close()
    return response.status, data


def state():
    status, data = get("/state.json")
    return json.loads(data) if status == 200 else None


def robot_view(doc, robot_id):
    for robot in doc.get("robots", []):
        if robot.get("id") == robot_id:
            return robot
    return None


def seen(doc):
    """Per robot: (has ROBOT_STATE, processes reporting, teammates present in its TEAM_STATE)."""
    result = {}
    for r in ROBOTS:
        view = robot_view(doc, r) or {}
        processes = {p.get("process") for p in view.get("processes", []) if not p.get("stale")}
        team = view.get("team_state") or {}
        present = [i + 1 for i, p in enumerate(team.get("present", [])) if p]
        result[r] = (view.get("robot_state") is not None, processes, present)
    return result


# 1. Both robots' buses reach the laptop: wait (bounded) until everything is seen.
deadline = time.time() + 90
last = None
while time.time() < deadline:
    try:
        doc = state()
    except (OSError, ValueError):
        doc = None
    if doc:
        last = seen(doc)
        if all(s[0] and PROCESSES <= s[1] and (3 - r) in s[2] for r, s in last.items()):
            break
    time.sleep(1)
print("laptop sees:", {r: {"robot_state": s[0], "processes": sorted(s[1]), "team_present": s[2]}
                       for r, s in (last or {}).items()})
for r, s in (last or {r: (False, set(), []) for r in ROBOTS}).items():
    if not s[0]:
        failures.append(f"no ROBOT_STATE of robot {r} on the laptop")
    if not PROCESSES <= s[1]:
        failures.append(f"robot {r}: processes missing on the laptop: {sorted(PROCESSES - s[1])}")
    if (3 - r) not in s[2]:
        failures.append(f"robot {r}'s TEAM_STATE does not show robot {3 - r} present")
if last:
    doc = state()
    for r in ROBOTS:
        rs = (robot_view(doc, r) or {}).get("robot_state") or {}
        print(f"robot {r}: status {rs.get('status')}, pose ({rs.get('x', 0):.2f}, "
              f"{rs.get('y', 0):.2f}, {rs.get('phi', 0):.2f})")

# 2. The camera view on the laptop: asking for it makes the viewer watch the robot's camera;
#    what arrives is the reduced stream.
frame = None
deadline = time.time() + 20
while time.time() < deadline and frame is None:
    status, data = get("/camera.json?robot=1")
    if status == 200:
        doc = json.loads(data)
        if doc.get("frame"):
            frame = doc["frame"]
    time.sleep(0.5)
if frame is None:
    failures.append("no camera frame of robot 1 in the laptop's camera view")
else:
    print(f"camera view of robot 1: stream {frame.get('stream')}, {frame.get('width')}x"
          f"{frame.get('height')} drawn from {frame.get('image_width')}x{frame.get('image_height')}"
          f", {frame.get('jpeg_bytes')} JPEG bytes")
    if frame.get("stream") != "preview":
        failures.append(f"the laptop's camera view shows the {frame.get('stream')} stream, "
                        "expected the reduced preview")
    if (frame.get("width"), frame.get("height")) != (640, 480):
        failures.append(f"camera view drawn {frame.get('width')}x{frame.get('height')}, "
                        "expected the camera's 640x480")

# 3. What the laptop hears on the robots' buses (what lcm-spy would show): no CAMERA_IMAGE.
stats = subprocess.run([f"{bin_dir}/fieldline-bus-stats", "--robots", "2", "--duration", "5",
                        "--json"], capture_output=True, text=True, timeout=30)
rows = [json.loads(l) for l in stats.stdout.splitlines() if l.strip()]
with open(f"{out_dir}/laptop_stats.jsonl", "w") as f:
    f.write(stats.stdout)
by = {(row["bus"], row["channel"]): row for row in rows}
for r in ROBOTS:
    bus = f"r{r}"
    total = sum(row["rate_hz"] * row["kb_per_msg"] for (b, _), row in by.items() if b == bus)
    print(f"laptop hears {bus}: " + ", ".join(
        f"{c} {row['rate_hz']:.1f} Hz x {row['kb_per_msg']:.1f} kB"
        for (b, c), row in sorted(by.items()) if b == bus) + f"; {total:.0f} kB/s in all")
    if (bus, "CAMERA_IMAGE") in by:
        failures.append(f"CAMERA_IMAGE of robot {r} reached the laptop: "
                        f"{by[(bus, 'CAMERA_IMAGE')]['count']} frames")
    preview = by.get((bus, "CAMERA_PREVIEW"), {})
    # The reduced stream: 160x120 YUYV (37.5 kB) of the 640x480 camera, none counted as foreign.
    if not 30.0 <= preview.get("kb_per_msg", 0.0) <= 45.0 or preview.get("foreign", 0) > 0:
        failures.append(f"{bus} CAMERA_PREVIEW on the laptop: {preview}, expected 160x120 "
                        "frames of about 37.5 kB")
    for channel, least in (("ROBOT_STATE", 20.0), ("CAMERA_PREVIEW", 0.5), ("SERVICE_STATUS", 1.0)):
        rate = by.get((bus, channel), {}).get("rate_hz", 0.0)
        if rate < least:
            failures.append(f"{bus} {channel} at {rate:.1f} Hz on the laptop, expected {least}+")

for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
