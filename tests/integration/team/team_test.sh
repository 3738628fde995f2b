#!/usr/bin/env bash
# The whole simulated team, as scripts/demo runs it, in a private network namespace: every robot's
# channels flow at their rates, images arrive with their configured latency, nothing restarts,
# and the launcher stops everything cleanly with exit code 0 at the end of --duration.
set -u
bin=$1
root=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
$ns bash -c "
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-launch' sim_team --duration 18 --no-table --status-period 5 > '$out/launch.log' 2>&1 &
  launcher=\$!
  sleep 9
  '$bin/fieldline-bus-stats' --robots 6 --sim --duration 5 --json > '$out/stats.jsonl'
  wait \$launcher
  echo \$? > '$out/launch.rc'
"
echo "--- launcher (last lines)"; tail -n 4 "$out/launch.log" | cut -c1-400
echo "--- bus statistics"; cat "$out/stats.jsonl"
python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
failures = []
rc = int((out / "launch.rc").read_text().strip() or "-1")
if rc != 0:
    failures.append(f"launcher exit code {rc}")
log = (out / "launch.log").read_text()
if "restarts=" in log:
    failures.append("a process was restarted")
stats = {(r["bus"], r["channel"]): r for r in map(json.loads, (out / "stats.jsonl").read_text().split("\n")[:-1])}
# Nominal rates; a loaded CI machine may lag, so the check is half of nominal. The latency of
# camera-derived messages is at least the configured 60 ms by construction (exposure stamping).
nominal = {"CAMERA_IMAGE": 30, "VISION_BALL": 30, "VISION_OBSTACLES": 30, "VISION_LINES": 10,
           "ODOMETRY": 50, "MOTION_COMMAND": 50}
for robot in range(1, 7):
    for channel, hz in nominal.items():
        r = stats.get((f"r{robot}", channel))
        if r is None:
            failures.append(f"r{robot} {channel}: no messages")
            continue
        if r["rate_hz"] < hz / 2:
            failures.append(f"r{robot} {channel}: {r['rate_hz']} Hz, expected about {hz}")
        if r["gaps"] > 0:
            failures.append(f"r{robot} {channel}: {r['gaps']} messages lost")
        if channel.startswith(("CAMERA", "VISION")) and not 59.5 <= r["latency_p50_ms"] < 200:
            failures.append(f"r{robot} {channel}: latency {r['latency_p50_ms']} ms")
sim = stats.get(("sim", "SIM_WORLD"))
if sim is None or sim["rate_hz"] < 50:
    failures.append(f"SIM_WORLD: {sim}")
for f in failures:
    print("FAIL:", f)
print("PASS" if not failures else f"{len(failures)} failures")
sys.exit(1 if failures else 0)
PY
