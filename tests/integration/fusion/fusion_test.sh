#!/usr/bin/env bash
# Fusion in the simulated team: every robot publishes ROBOT_STATE at 50 Hz and BALL_STATE at
# 30 Hz (judged by its stamps' median interval), reaches TRACKING within 2 s of its first line
# frame, and stays on the right half; the pilots steer with ROBOT_STATE (not the simulator's
# truth) and the robots really drive their scripts on it, staying localized; the launcher stops
# cleanly. Rates are checked at a margin (a loaded machine lags), not timed.
#
#   fusion_test.sh BIN ROOT [SHARE]
#
# With SHARE (ctest gives one: the fixture team_recording, tests/integration/fusion/CMakeLists.txt)
# the run is also recorded (fieldline-eval --record: fieldline-record --team, every bus, no
# images) into SHARE/rec and its live evaluation kept in SHARE/live, for the tests that read a
# recording of the six-robot team (replay_demo_recording, viewer_browser_plays_a_recording)
# instead of starting the team again each.
set -u
bin=$1
root=$2
share=${3:-}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
record=""
if [ -n "$share" ]; then
  rm -rf "$share"
  mkdir -p "$share"
  record="--record '$share/rec'"
fi
# Private network and mount namespaces: its own buses and its own /tmp/fieldline (the
# simulator's serial lines and snapshot, fusion's pose files), not a running demo's.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
$ns bash -c "
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-eval' --scenario default --robots 6 --duration 25 --out '$out' $record > '$out/eval.txt' 2> '$out/eval.err'
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
    # BALL_STATE comes from a 30 Hz timer that skips the ticks it missed: its rate over the run
    # falls with the machine's load (22.7 Hz over 14 s with a busy loop beside; 22-27 Hz in the
    # demo team with one), its stamps' median interval stays the timer's 33.3 ms until half the
    # ticks are lost. That median shows a wrong or missing timer; the longest interval (at most
    # 2 s: a loaded machine pauses a process for 0.5 s at worst) a fusion that stops publishing
    # for a while; half the rate, one that publishes too little.
    bhz = summary["ball_state_hz"].get(robot, 0)
    interval = summary.get("ball_state_interval_p50_ms", {}).get(robot, 0)
    longest = summary.get("ball_state_interval_max_ms", {}).get(robot, float("inf"))
    if bhz < 15 or not 30.0 <= interval <= 36.7 or longest > 2000:
        failures.append(f"r{robot} BALL_STATE {bhz} Hz, median interval {interval} ms, longest "
                        f"{longest} ms, expected 30 Hz (33.3 ms)")
    # From the robot's first line frame: a loaded machine may start its cameras late.
    after = summary["tracking_after_vision_s"].get(robot, -1)
    if not 0 <= after <= 2.0:
        failures.append(f"r{robot} TRACKING {after} s after its first VISION_LINES, expected within 2 s")
if summary["wrong_half"] != 0:
    failures.append(f"{summary['wrong_half']} wrong-half commits")
# The pilots steer with their own estimate: the launch file the run used says --steer state.
launch = (out / "launch.yaml").read_text()
pilot = launch[launch.index("name: pilot"):]
pilot = pilot[:pilot.index("- name:", 1)] if "- name:" in pilot[1:] else pilot
if "--steer, state" not in pilot or "truth" in pilot:
    failures.append("the pilots do not steer with ROBOT_STATE: " + pilot.strip()[:200])
# ... and drive on it: the robots with a moving script (1: figure eight, 2: waypoints) covered
# metres of true path, and every robot's estimate stayed near its truth while they did.
import csv, math
path = {}
last = {}
errors = {}
with open(out / "samples.csv") as f:
    for row in csv.DictReader(f):
        r = row["robot"]
        p = (float(row["true_x"]), float(row["true_y"]))
        if r in last:
            path[r] = path.get(r, 0.0) + math.dist(p, last[r])
        last[r] = p
        if row["status"] == "2":
            errors.setdefault(r, []).append(float(row["pos_error_m"]))
for r in ("1", "2"):
    if path.get(r, 0.0) < 3.0:
        failures.append(f"r{r} drove {path.get(r, 0.0):.1f} m of its script, expected > 3 m")
for r, e in sorted(errors.items()):
    mean = sum(e) / len(e)
    print(f"r{r}: true path {path.get(r, 0.0):.1f} m, mean error while tracking {100 * mean:.1f} cm")
    if mean > 0.10:
        failures.append(f"r{r} mean error {mean:.3f} m while tracking, expected under 0.10 m")
log = (out / "launch.log").read_text()
if "restarts=" in log:
    failures.append("a process was restarted")
for f in failures:
    print("FAIL:", f)
print("PASS" if not failures else f"{len(failures)} failures")
sys.exit(1 if failures else 0)
PY
rc=$?
if [ -n "$share" ]; then
  # The live evaluation beside the recording (its summary.json is what the replay compares with);
  # kept only for a passing run (a failed fixture makes its dependent tests not run).
  mkdir -p "$share/live"
  cp "$out/summary.json" "$out/eval.txt" "$out/launch.yaml" "$share/live/" 2> /dev/null
  [ -f "$out/record.log" ] && cp "$out/record.log" "$share/live/"
  [ "$rc" = 0 ] || rm -rf "$share/rec"
fi
exit "$rc"
