#!/usr/bin/env bash
# Issue 32 item 2 (graceful degradation), briefly: two robots of the default scenario for 18 s
# with every camera forced down to 10 Hz (`--camera-fps 10`) and a bounded busy loop taking one
# core beside them (`--cpu-hog 1`, started and ended by fieldline-eval). Asserted on
# summary.json and robustness.json, the issue's loaded-match conditions: wrong_half 0, no sample
# with status TRACKING more than 0.5 m from the truth, p99 over the TRACKING samples at most
# 0.3 m, not TRACKING for at most 10 % of the time; and the cameras really ran at 10 Hz (the
# launch file the run used passes --fps 10). The whole 60 s match with six robots is in
# docs/faults.md (too heavy for CI).
set -u
bin=$(realpath "$1")
root=$(realpath "$2")
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# The run, in private namespaces: run_eval.sh (shared with the other eval test).
"$(dirname "$(realpath "$0")")/run_eval.sh" "$bin" "$root" "$out" \
  --scenario default --robots 2 --duration 18 \
  --cpu-hog 1 --camera-fps 10
rc=$?
[ "$rc" -eq 0 ] || exit "$rc"
python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
failures = []
rc = int((out / "eval.rc").read_text().strip() or "-1")
if rc != 0:
    failures.append(f"fieldline-eval exit code {rc}")
s = json.loads((out / "summary.json").read_text())
r = json.loads((out / "robustness.json").read_text())
print(json.dumps(r, indent=1))
if "1 CPU hog(s) running" not in (out / "eval.err").read_text():
    failures.append("no CPU hog ran")
# The cameras ran at 10 Hz: one VISION_LINES per frame (sim_team: --lines-every 1).
for robot, hz in r["vision_lines_hz"].items():
    if not 7.0 <= hz <= 10.5:
        failures.append(f"robot {robot}: VISION_LINES at {hz} Hz, expected 10")
if len(r["vision_lines_hz"]) != 2:
    failures.append(f"VISION_LINES rates of {sorted(r['vision_lines_hz'])}, expected robots 1 and 2")
if s["wrong_half"] != 0:
    failures.append(f"wrong_half {s['wrong_half']}")
if r["tracking_over_limit"] != 0:
    failures.append(f"{r['tracking_over_limit']} TRACKING samples more than 0.5 m off "
                    f"(worst {r['tracking_max_m']:.3f} m, robot {r['worst_robot']} at {r['worst_t_s']} s)")
if r["tracking_p99_m"] > 0.3:
    failures.append(f"p99 over TRACKING {r['tracking_p99_m']:.3f} m > 0.3 m")
if r["not_tracking_share"] > 0.10:
    failures.append(f"not TRACKING {100 * r['not_tracking_share']:.1f} % of the time > 10 %")
if r["tracking_samples"] < 500:
    failures.append(f"only {r['tracking_samples']} TRACKING samples")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
PY
