#!/usr/bin/env bash
# Fusion in the simulated team: every robot publishes ROBOT_STATE at 50 Hz and BALL_STATE at
# 30 Hz, reaches TRACKING within 2 s of its first line frame, and stays on the right half; the
# launcher stops cleanly. Rates are checked at a margin (a loaded machine lags), not timed.
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
  '$bin/fieldline-eval' --scenario default --robots 6 --duration 25 --out '$out' > '$out/eval.txt' 2> '$out/eval.err'
  echo \$? > '$out/eval.rc'
"
echo "--- eval"; cat "$out/eval.err" "$out/eval.txt"
echo "--- launcher (last lines)"; tail -n 4 "$out/launch.log" | cut -c1-400
python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
failures = []
rc = int((out / "eval.rc").read_text().strip() or "-1")
if rc != 0:
    failures.append(f"fieldline-eval exit code {rc}")
summary = json.loads((out / "summary.json").read_text())
print(json.dumps(summary, indent=1))
for robot in map(str, range(1, 7)):
    hz = summary["robot_state_hz"].get(robot, 0)
    if hz < 40:
        failures.append(f"r{robot} ROBOT_STATE {hz} Hz, expected 50")
    bhz = summary["ball_state_hz"].get(robot, 0)
    if bhz < 24:
        failures.append(f"r{robot} BALL_STATE {bhz} Hz, expected 30")
    # From the robot's first line frame: a loaded machine may start its cameras late.
    after = summary["tracking_after_vision_s"].get(robot, -1)
    if not 0 <= after <= 2.0:
        failures.append(f"r{robot} TRACKING {after} s after its first VISION_LINES, expected within 2 s")
if summary["wrong_half"] != 0:
    failures.append(f"{summary['wrong_half']} wrong-half commits")
log = (out / "launch.log").read_text()
if "restarts=" in log:
    failures.append("a process was restarted")
for f in failures:
    print("FAIL:", f)
print("PASS" if not failures else f"{len(failures)} failures")
sys.exit(1 if failures else 0)
PY
