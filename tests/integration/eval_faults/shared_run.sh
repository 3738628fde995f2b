# Sourced by the tests that judge eval_team_run.sh's shared run (ctest's fixture eval_faults).
# shared_run_ready DIR: prints the run's output; returns 77 when the run was skipped, 1 when
# there is no run in DIR.
shared_run_ready() {
  [ -f "$1/skipped" ] && { echo "SKIP: the run was skipped (eval_team_run.sh)"; return 77; }
  [ -f "$1/eval.rc" ] || { echo "FAIL: no run in $1 (eval_team_run.sh)"; return 1; }
  cat "$1/eval.err" "$1/eval.txt"
}
