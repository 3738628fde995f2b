#!/usr/bin/env bash
# Shared by eval_faults_test.sh and eval_loaded_test.sh: runs `fieldline-eval --out OUT ARGS...`
# in a private network namespace (the buses) and mount namespace (the simulator's /tmp/fieldline:
# its pseudo-terminals and state file are shared by every run on the machine otherwise); its
# stdout goes to OUT/eval.txt, stderr to OUT/eval.err, its exit code to OUT/eval.rc, and both are
# printed. Exits 77 (the tests' skip) when the namespaces cannot be made, 0 otherwise.
# usage: run_eval.sh BIN ROOT OUT EVAL_ARGS...
set -u
bin=$1 root=$2 out=$3
shift 3
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
if ! $ns true 2>/dev/null; then
  echo "SKIP: needs private network and mount namespaces (root or user namespaces)"
  exit 77
fi
$ns bash -s "$bin" "$root" "$out" "$@" <<'SH'
bin=$1 root=$2 out=$3
shift 3
ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
export FIELDLINE_ROOT="$root"
"$bin/fieldline-eval" --out "$out" "$@" > "$out/eval.txt" 2> "$out/eval.err"
echo $? > "$out/eval.rc"
SH
echo "--- eval"; cat "$out/eval.err" "$out/eval.txt"
exit 0
