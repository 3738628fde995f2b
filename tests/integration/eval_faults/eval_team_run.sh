#!/usr/bin/env bash
# One run of two robots of the default scenario with the faults of both eval_fault_scenarios and
# eval_clock_steps (ctest's fixture eval_faults, CMakeLists.txt says why), into OUT for their
# checks (eval_faults_test.sh BIN ROOT OUT, eval_clockstep_test.sh BIN ROOT OUT):
#    6 s      robot 1's fusion restarted (SIGTERM)
#   10 s      robot 2's processes stalled for 1.5 s (SIGSTOP, SIGCONT)
#   14 s      robot 1's processes restarted on a clock 2 s ahead
#   19 s      ... and on one 2 s behind that (its launch file's clock again)
#   25 s      the end: 6 s after the last step, as in eval_clock_steps' own run (16 s, steps at 5
#             and 10 s); every fault 4-5 s from the next, as in the two runs before.
# Exits 77 (and leaves OUT/skipped) when the namespaces cannot be made, 1 when fieldline-eval
# left no robustness.json, 0 otherwise: the checks judge the run.
# usage: eval_team_run.sh BIN ROOT OUT
set -u
bin=$(realpath "$1")
root=$(realpath "$2")
out=$3
rm -rf "$out"
mkdir -p "$out"
"$(dirname "$(realpath "$0")")/run_eval.sh" "$bin" "$root" "$out" \
  --scenario default --robots 2 --duration 25 \
  --fault restart:fusion/1@6 --fault stall:2@10+1.5 \
  --fault clockstep:1@14+2 --fault clockstep:1@19-2
rc=$?
if [ "$rc" = 77 ]; then
  touch "$out/skipped"
  exit 77
fi
[ -f "$out/robustness.json" ] || { echo "FAIL: fieldline-eval wrote no robustness.json"; exit 1; }
exit "$rc"
