# Sourced by the tests that judge a fieldline-eval run of faults: eval_team_run.sh's shared run
# (ctest's fixture eval_faults) or, run by hand without one, a run of their own.

# shared_run_ready DIR: prints the run's output; returns 77 when the run was skipped, 1 when
# there is no run in DIR.
shared_run_ready() {
  [ -f "$1/skipped" ] && { echo "SKIP: the run was skipped (eval_team_run.sh)"; return 77; }
  [ -f "$1/eval.rc" ] || { echo "FAIL: no run in $1 (eval_team_run.sh)"; return 1; }
  cat "$1/eval.err" "$1/eval.txt"
}

# eval_run_or_shared RUN BIN ROOT ARGS...: sets `out` to RUN when one is given (checked by
# shared_run_ready), else runs run_eval.sh with ARGS into a temporary folder removed at exit.
eval_run_or_shared() {
  local run=$1 bin=$2 root=$3
  shift 3
  if [ -n "$run" ]; then
    out=$run
    shared_run_ready "$out"
    return
  fi
  out=$(mktemp -d)
  trap 'rm -rf "$out"' EXIT
  "$(dirname "${BASH_SOURCE[0]}")/run_eval.sh" "$bin" "$root" "$out" "$@"
}
