#!/usr/bin/env bash
# fieldline-eval's fault scenarios (issue 34 item 3), briefly: two robots of the default scenario
# for 18 s; robot 1's fusion is stopped with SIGTERM at 6 s (the launcher restarts it: it starts
# from UNKNOWN and must localize again) and robot 2's processes are stalled with SIGSTOP at 10 s
# for 1.5 s (a machine that stops scheduling them), then continued. Asserted on robustness.json:
# each fault reached its processes, each affected robot recovered (TRACKING within 0.2 m for 1 s)
# before the run ended, and no sample with status TRACKING was more than 0.5 m from the truth.
# Times are not asserted (the machine is shared): recovery only has to happen.
set -u
bin=$(realpath "$1")
root=$(realpath "$2")
# With a third argument, the shared run of eval_team_run.sh (ctest's fixture eval_faults): its
# faults are at other times, the same ones, judged the same way.
. "$(dirname "$(realpath "$0")")/shared_run.sh"
eval_run_or_shared "${3:-}" "$bin" "$root" --scenario default --robots 2 --duration 18 \
  --fault restart:fusion/1@6 --fault stall:2@10+1.5 || exit $?
python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
failures = []
rc = int((out / "eval.rc").read_text().strip() or "-1")
if rc != 0:
    failures.append(f"fieldline-eval exit code {rc}")
r = json.loads((out / "robustness.json").read_text())
print(json.dumps(r, indent=1))
faults = {f["fault"]: f for f in r["faults"]}
for name, robots in (("restart:fusion/1@6", ["1"]), ("stall:2@10+1.5", ["2"])):
    f = faults.get(name)
    if f is None:
        failures.append(f"{name}: not in robustness.json")
        continue
    if f["processes"] < 1:
        failures.append(f"{name}: reached no process")
    if sorted(f["recovery_s"]) != robots:
        failures.append(f"{name}: affected {sorted(f['recovery_s'])}, expected {robots}")
    if f["recovery_max_s"] < 0:
        failures.append(f"{name}: never recovered (TRACKING within 0.2 m for 1 s)")
# The stall stopped every process of robot 2 (7 in sim_team: camera, region tracking, motor
# bridge, pilot, feature recognition, fusion, team link).
stall = faults.get("stall:2@10+1.5", {})
if stall and stall["processes"] != 7:
    failures.append(f"the stall stopped {stall['processes']} processes of robot 2, expected 7")
if r["tracking_over_limit"] != 0:
    failures.append(f"{r['tracking_over_limit']} TRACKING samples more than 0.5 m from the truth "
                    f"(worst {r['tracking_max_m']:.3f} m, robot {r['worst_robot']} at {r['worst_t_s']} s)")
if r["tracking_samples"] < 500:
    failures.append(f"only {r['tracking_samples']} TRACKING samples")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
PY
