#!/usr/bin/env bash
# fieldline-eval's clock steps (issue 34 item 3), briefly: two robots of the default scenario for
# 16 s; at 5 s the launcher restarts robot 1's processes on a clock 2 s ahead
# (clockstep:1@5+2), at 10 s on one 2 s behind that (clockstep:1@10-2: its launch file clock
# again). Robot 1, whose figure eight stays in its own half, is the one stepped: a robot restarted
# in the opponent's half commits to its twin (docs/faults.md). Asserted: the launcher restarted
# robot 1's seven processes on each new clock (launch.log), and per step in robustness.json: the
# robot recovered (TRACKING within 0.2 m for 1 s, its stamps taken out with its new clock), no
# TRACKING sample of it beyond 0.5 m, and robot 2's TEAM_STATE had it back (present, with a pose
# taken after the step). Times are not asserted (the machine is shared).
set -u
bin=$(realpath "$1")
root=$(realpath "$2")
# With a third argument, the shared run of eval_team_run.sh (ctest's fixture eval_faults): its
# faults are at other times, the same ones, judged the same way.
. "$(dirname "$(realpath "$0")")/shared_run.sh"
eval_run_or_shared "${3:-}" "$bin" "$root" --scenario default --robots 2 --duration 16 \
  --fault clockstep:1@5+2 --fault clockstep:1@10-2 || exit $?
grep "clock stepped" "$out/launch.log"
python3 - "$out" <<'PY'
import json, pathlib, re, sys
out = pathlib.Path(sys.argv[1])
failures = []
rc = int((out / "eval.rc").read_text().strip() or "-1")
if rc != 0:
    failures.append(f"fieldline-eval exit code {rc}")
# Robot 1's clock: the launch file's offset, +2 s, then back.
initial = float(re.search(r"id: 1, clock: \{offset_s: ([-0-9.]+)", (out / "launch.yaml").read_text())[1])
steps = [float(s) for s in re.findall(r"r1's clock stepped to ([-+0-9.]+) s: restarting its 7 ",
                                       (out / "launch.log").read_text())]
expected = [initial + 2.0, initial]
if len(steps) != 2 or any(abs(s - e) > 1e-6 for s, e in zip(steps, expected)):
    failures.append(f"launch.log: robot 1's 7 processes restarted on clocks {steps}, expected {expected}")
r = json.loads((out / "robustness.json").read_text())
print(json.dumps(r["faults"], indent=1))
# The two steps of robot 1, in their order: 2 s ahead, then 2 s behind that (clockstep:1@5+2 and
# clockstep:1@10-2 in this test's own run, @14+2 and @19-2 in eval_team_run.sh's).
steps_run = [f for f in r["faults"] if f["fault"].startswith("clockstep:1@")]
if [f["fault"][-2:] for f in steps_run] != ["+2", "-2"]:
    failures.append(f"robustness.json: robot 1's clock steps {[f['fault'] for f in steps_run]}, "
                    "expected one 2 s ahead, then one 2 s behind")
for f, robot, teammate in zip(steps_run, ("1", "1"), ("2", "2")):
    name = f["fault"]
    if f["processes"] != 7:
        failures.append(f"{name}: found {f['processes']} processes of robot {robot}, expected 7")
    if list(f["recovery_s"]) != [robot] or f["recovery_max_s"] < 0:
        failures.append(f"{name}: robot {robot} never recovered ({f['recovery_s']})")
    if f["tracking_over_limit"] != 0:
        failures.append(f"{name}: {f['tracking_over_limit']} TRACKING samples beyond 0.5 m "
                        f"(largest {f['max_tracking_error_m']:.3f} m)")
    if f.get("heard_again_s", {}).get(teammate, -1) < 0:
        failures.append(f"{name}: robot {teammate} never heard robot {robot} again "
                        f"({f.get('heard_again_s')}, {f.get('packets_refused')} packets refused)")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
PY
