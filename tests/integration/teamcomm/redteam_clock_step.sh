#!/usr/bin/env bash
# Red-team finding 2 of issue 34, as the red team did it: in a running team of three robots
# (fieldline-teamcomm and a probe standing in for fusion, each robot on its own bus, the team link
# on the loopback of a private network namespace), robot 1's processes are restarted on a clock
# 2 s ahead (+2 s), then on the true clock (-2 s), then 2 s behind (-2 s). After each step both
# teammates must show robot 1 present with a fresh pose within 5 s, and their SERVICE_STATUS
# reason while it is refused must name robot 1's clock, never a sequence number.
# Failed on main at 32dcf7a: robot 1 was never present again after the first step.
#
#   redteam_clock_step.sh BIN_DIR SOURCE_DIR
set -u
if [ -z "${FIELDLINE_PRIVATE_NS:-}" ] && ! unshare -n -m --propagation private true 2>/dev/null &&
  ! unshare -r -n -m --propagation private true 2>/dev/null; then
  echo "SKIP: needs private network and mount namespaces (root or unprivileged user namespaces)"
  exit 77
fi
# Its own buses and its own /tmp/fieldline, as every test that starts processes: a parallel run or
# a running demo shares no file with it.
. "$(dirname "$0")/../lib/private_ns.sh" "$@"
bin=$(realpath "$1")
root=$(realpath "$2")
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

bash -s "$bin" "$root" "$out" <<'EOF'
set -u
bin=$1 root=$2 out=$3
export FIELDLINE_ROOT="$root" FIELDLINE_CLOCK_REFERENCE_US=$(date +%s%6N)
# start ROBOT OFFSET_US TAG SECONDS X: teamcomm and the probe of one robot on that clock, the robot
# at (X, 1.5) (each of robot 1's processes at its own x, so the pictures tell them apart).
start() {
  FIELDLINE_CLOCK_OFFSET_US=$2 "$bin/fieldline-teamcomm" --robot $1 --team-config sim_team \
    > "$out/teamcomm$1$3.log" 2>&1 &
  echo $! >> "$out/teamcomm.pids"
  echo $! > "$out/teamcomm$1.pid"
  FIELDLINE_CLOCK_OFFSET_US=$2 "$bin/fieldline-team-probe" --robot $1 --pose "$5,1.5,0.3" \
    --ball 2.0,-1.0 --duration $4 --out "$out/probe$1$3.jsonl" > "$out/probe$1$3.log" 2>&1 &
  echo $! > "$out/probe$1.pid"
}
# step OFFSET_US TAG X: robot 1's processes restarted on another clock.
step() {
  kill -TERM "$(cat "$out/teamcomm1.pid")" "$(cat "$out/probe1.pid")"
  echo "$(date +%s%6N) $1 $3" >> "$out/steps"
  start 1 $1 $2 120 $3
}
# seen X: both teammates heard robot 1 present, with a fresh pose at x = X (its newest processes),
# and one more status of their team link after that (the reasons the analysis reads).
seen() {
  python3 - "$out" "$1" <<'PY'
import json, sys
out, x = sys.argv[1], float(sys.argv[2])
for robot in (2, 3):
    back, status_after = None, False
    try:
        lines = open(f"{out}/probe{robot}.jsonl").read().splitlines()
    except OSError:
        sys.exit(1)
    for line in lines:
        try:
            d = json.loads(line)
        except ValueError:
            continue
        if back is None and "present" in d and d["present"][0] and d["age"][0] < 200_000 \
                and abs(d["x"][0] - x) < 0.05:
            back = d["t"]
        if back is not None and d.get("status_t", 0) > back + 1_000_000:
            status_after = True
    if not status_after:
        sys.exit(1)
PY
}
. "$root/tests/integration/lib/wait.sh"
start 2 0 "" 120 2.0
start 3 0 "" 120 3.0
start 1 0 a 120 1.0
# Each step comes once the teammates have robot 1 back (generous bounds: the analysis below
# judges the 5 s).
wait_for 60 "robot 1 seen by its teammates at the start" seen 1.0
step 2000000 b 1.1
wait_for 30 "robot 1 back after the +2 s step" seen 1.1
step 0 c 1.2
wait_for 30 "robot 1 back after the -2 s step" seen 1.2
step -2000000 d 1.3
wait_for 30 "robot 1 back after the second -2 s step" seen 1.3
kill -TERM $(cat "$out/teamcomm.pids") $(cat "$out/probe"*.pid) 2>/dev/null
wait
EOF

python3 - "$out" <<'EOF'
import json, sys
out = sys.argv[1]
steps = [line.split() for line in open(f"{out}/steps")]
failures = 0
for robot in (2, 3):
    states, statuses = [], []
    for line in open(f"{out}/probe{robot}.jsonl"):
        d = json.loads(line)
        if "present" in d:
            states.append(d)
        elif "status_t" in d:
            statuses.append(d)
    previous = 0
    for i, (when, offset, x) in enumerate(steps):
        when, step, x = int(when), int(offset) - previous, float(x)
        previous = int(offset)
        end = int(steps[i + 1][0]) if i + 1 < len(steps) else float("inf")
        back = next((s for s in states
                     if when < s["t"] < end and s["present"][0] and s["age"][0] < 200_000
                     and abs(s["x"][0] - x) < 0.05), None)
        if back is None:
            print(f"FAIL: robot {robot} never saw robot 1 again after its {step:+d} us step")
            failures += 1
            continue
        delay = (back["t"] - when) / 1e6
        reasons = sorted({s.get("reason", "") for s in statuses
                          if when < s["status_t"] < back["t"] + 1_000_000 and s["state"] != 0})
        bad = [r for r in reasons if "sequence" in r or ("robot 1" in r and "clock" not in r)]
        clock = [r for r in reasons if "robot 1" in r and "clock" in r]
        print(f"robot {robot}: robot 1 back {delay:.2f} s after its {step:+d} us step; "
              f"reason: {(clock or reasons or ['none (ok)'])[0]}")
        if delay > 5.0:
            print("FAIL: more than 5 s")
            failures += 1
        if bad:
            print(f"FAIL: reason not the clock: {bad}")
            failures += 1
print("PASS" if failures == 0 else f"FAIL: {failures}")
sys.exit(1 if failures else 0)
EOF
