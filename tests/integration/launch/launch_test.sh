#!/usr/bin/env bash
# End-to-end test of fieldline-launch, run by ctest inside its own network namespace:
#  1. two test nodes on the buses of robots 1 and 2 both publish (seen in the launcher's status
#     lines, which come from their SERVICE_STATUS), a missing `optional` executable is skipped with
#     a warning;
#  2. one node killed with SIGKILL is restarted and publishes again;
#  3. SIGTERM to the launcher stops everything, the launcher exits 0 and no node is left;
#  4. a node that ignores SIGTERM is killed after the grace period;
#  5. the launcher killed with SIGKILL takes its nodes down (PR_SET_PDEATHSIG).
# In private network and mount namespaces (lib/private_ns.sh: its own buses and /tmp/fieldline).
# Usage: launch_test.sh PATH/TO/fieldline-launch PATH/TO/fieldline-launch-test-node
set -euo pipefail

launcher=$1
test_node=$2

. "$(dirname "$0")/../lib/private_ns.sh" "$@"

if [[ "$(dirname "$launcher")" != "$(dirname "$test_node")" ]]; then
  echo "FAIL: $test_node must be next to $launcher (both in the build's bin/)"
  exit 1
fi

work=$(mktemp -d)
tag="launchtest-$$-$RANDOM"
launcher_pid=""

# Processes of this test, found by the unique tag on their command lines.
our_pids() { pgrep -f -- "--tag $tag" || true; }

cleanup() {
  local pids
  if [[ -n "$launcher_pid" ]]; then kill -9 "$launcher_pid" 2>/dev/null || true; fi
  pids=$(our_pids)
  if [[ -n "$pids" ]]; then kill -9 $pids 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*"
  echo "----- launcher output ($log) -----"
  cat "$log" || true
  exit 1
}

# wait_for DESCRIPTION COMMAND...: polls COMMAND every 0.1 s, gives up after 60 s.
wait_for() {
  local what=$1
  shift
  for _ in $(seq 1 600); do
    if "$@"; then return 0; fi
    sleep 0.1
  done
  fail "timed out waiting for: $what"
}

log_has() { grep -qE -- "$1" "$log"; }
launcher_gone() { ! kill -0 "$launcher_pid" 2>/dev/null; }
none_left() { [[ -z "$(our_pids)" ]]; }
rate='(0\.[1-9]|[1-9][0-9]*\.[0-9])Hz'

cat >"$work/team.yaml" <<YAML
defaults:
  robots: 2
  restart: always
  stop_grace_s: 5
  backoff: {initial_s: 0.2, max_s: 1.0, stable_s: 60}
processes:
  - name: test_node
    executable: fieldline-launch-test-node
    robots: all
    args: [--tag, "$tag-r{robot}"]
  - name: not_built
    executable: fieldline-launch-test-missing
    robots: [1]
    # Without this, an executable that is not found is an error (a typo).
    optional: true
YAML

echo "== dry run"
log="$work/dry.log"
"$launcher" "$work/team.yaml" --dry-run >"$log" 2>&1 || fail "--dry-run exited non-zero"
log_has "fieldline-launch-test-node --robot 2 --bus-url 'udpm://239\.255\.76\.67:7669\?ttl=0&recv_buf_size=[0-9]+' --sim-bus-url 'udpm://239\.255\.76\.67:7667\?ttl=0&recv_buf_size=[0-9]+' --tag $tag-r2" ||
  fail "--dry-run does not show robot 2's command line"
log_has "^# \[r1 not_built\].*NOT BUILT" || fail "--dry-run does not flag the missing executable"

echo "== two nodes on two robot buses"
log="$work/team.log"
"$launcher" "$work/team.yaml" --no-table --status-period 1 >"$log" 2>&1 &
launcher_pid=$!
wait_for "robot 1's node output, prefixed" log_has "^\[r1 test_node\] test node up: robot 1 tag $tag-r1"
wait_for "robot 2's node output, prefixed" log_has "^\[r2 test_node\] test node up: robot 2 tag $tag-r2"
log_has "warning: fieldline-launch-test-missing is not built .*skipping r1 not_built" ||
  fail "no warning about the executable that is not built"
wait_for "both nodes publishing (status line)" \
  log_has "status: .*r1 test_node ok $rate.*r2 test_node ok $rate"

echo "== SIGKILL one node: it is restarted"
old_pid=$(pgrep -f -- "--tag $tag-r1\$")
[[ $(wc -w <<<"$old_pid") -eq 1 ]] || fail "expected one robot-1 node, found: $old_pid"
kill -9 "$old_pid"
restarted() {
  local pid
  pid=$(pgrep -f -- "--tag $tag-r1\$" || true)
  [[ -n "$pid" && "$pid" != "$old_pid" ]]
}
wait_for "a new robot-1 node" restarted
log_has "r1 test_node ended \(killed by SIGKILL after [0-9.]+ s\); restarting in 0\.2 s" ||
  fail "the launcher did not report the crash and the restart delay"
wait_for "the restarted node publishing" \
  log_has "status: .*r1 test_node ok $rate restarts=1.*r2 test_node ok $rate"

echo "== SIGTERM to the launcher: everything stops"
kill -TERM "$launcher_pid"
wait_for "the launcher to exit" launcher_gone
rc=0
wait "$launcher_pid" || rc=$?
launcher_pid=""
[[ $rc -eq 0 ]] || fail "launcher exit code $rc after SIGTERM, expected 0"
none_left || fail "processes left after the launcher stopped: $(our_pids)"
log_has "^\[r1 test_node\] test node robot 1 stopping" || fail "robot 1's node was not stopped by SIGTERM"
log_has "^\[r2 test_node\] test node robot 2 stopping" || fail "robot 2's node was not stopped by SIGTERM"
log_has "r2 test_node stopped \(exit code 0" || fail "the launcher did not report robot 2's clean stop"

echo "== a node that ignores SIGTERM is killed after the grace period"
cat >"$work/stubborn.yaml" <<YAML
defaults:
  stop_grace_s: 1
processes:
  - name: stubborn
    executable: fieldline-launch-test-node
    robots: [1]
    args: [--tag, "$tag-stubborn", --ignore-sigterm]
YAML
log="$work/stubborn.log"
"$launcher" "$work/stubborn.yaml" --no-table >"$log" 2>&1 &
launcher_pid=$!
wait_for "the stubborn node" log_has "^\[r1 stubborn\] test node up"
kill -TERM "$launcher_pid"
wait_for "the launcher to exit" launcher_gone
rc=0
wait "$launcher_pid" || rc=$?
launcher_pid=""
[[ $rc -eq 0 ]] || fail "launcher exit code $rc, expected 0"
log_has "r1 stubborn did not stop within 1\.0 s: SIGKILL" || fail "no SIGKILL after the grace period"
none_left || fail "processes left: $(our_pids)"

echo "== SIGKILL to the launcher: the nodes die with it"
log="$work/orphans.log"
"$launcher" "$work/team.yaml" --no-table >"$log" 2>&1 &
launcher_pid=$!
wait_for "robot 1's node" log_has "^\[r1 test_node\] test node up"
wait_for "robot 2's node" log_has "^\[r2 test_node\] test node up"
kill -9 "$launcher_pid"
wait "$launcher_pid" 2>/dev/null || true
launcher_pid=""
wait_for "no node left after the launcher was killed" none_left

echo "PASS"
