#!/usr/bin/env bash
# Issue 13 findings 6, 7 and 8 end to end, inside a private network namespace (every wait
# bounded):
#  1. `bus.group: 239.255.76.999` fails --dry-run (exit 2, the key named) instead of every
#     process exiting 3 at run time;
#  2. a typo in a child's args (--feild) fails --dry-run: the child was run with --check-args;
#  3. a typo in `executable:` is an error with the closest built name, not a warning;
#  4. the shipped launch files pass --dry-run: every fieldline executable they start accepts
#     --check-args with their arguments; real_robot.yaml only with its devices there (stand-ins:
#     a named pipe for the camera, /dev/null for the serial line): without them it fails naming
#     each missing device with its fix, and so do the camera's and the motor bridge's
#     --check-args;
#  5. a child that crash-loops (started with --skip-check-args) is FAILED and the launcher exits 1
#     even though --duration ended the run (it used to exit 0 and restart forever);
#  6. `fieldline-camera --fps 1000` exits 2, and a camera preset naming a colour table that does
#     not exist fails its --check-args with exit 2.
# Usage: launch_checks.sh BUILD/bin SOURCE_ROOT
set -euo pipefail
bin=$1
root=$2
export FIELDLINE_ROOT="$root"

# Private network and mount namespaces: its own buses and its own /tmp/fieldline.
. "$(dirname "$0")/../lib/private_ns.sh" "$@"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
log=""
fail() {
  echo "FAIL: $*"
  [[ -n "$log" ]] && { echo "----- $log -----"; cat "$log"; }
  exit 1
}
# expect_rc CODE LOG COMMAND...: runs COMMAND (bounded by timeout) with its output in LOG.
expect_rc() {
  local want=$1
  log=$2
  shift 2
  local rc=0
  timeout 300 "$@" >"$log" 2>&1 || rc=$?
  [[ $rc -eq $want ]] || fail "exit code $rc, expected $want: $*"
}
has() { grep -qE -- "$1" "$log" || fail "no line matching '$1' in $log"; }

team() {  # team FILE EXTRA-DEFAULTS ARGS EXECUTABLE
  cat >"$1" <<YAML
defaults:
  robots: 2
  restart: always
  backoff: {initial_s: 0.05, max_s: 0.2, stable_s: 60}
  crash_loop: {restarts: 4, window_s: 30}
$2
processes:
  - name: node
    executable: ${4:-fieldline-launch-test-node}
    robots: all
    args: $3
YAML
}

echo "== 1. a multicast group that is not one fails --dry-run"
team "$work/group.yaml" "  bus: {group: 239.255.76.999}" "[--tag, x]"
expect_rc 2 "$work/group.log" "$bin/fieldline-launch" "$work/group.yaml" --dry-run
has "group.yaml:6: defaults.bus.group: '239\.255\.76\.999' is not an IPv4 address"

echo "== 2. a typo in a child's arguments fails --dry-run"
team "$work/args.yaml" "" "[--feild, msl]"
expect_rc 2 "$work/args.log" "$bin/fieldline-launch" "$work/args.yaml" --dry-run
has "error: r1 node: arguments rejected \(exit code 2\): .*--feild"
has "error: r2 node: arguments rejected"
has "2 problem\(s\) in .*args\.yaml: nothing would start"
echo "   ... and the same file does not start either"
expect_rc 2 "$work/args_run.log" "$bin/fieldline-launch" "$work/args.yaml" --duration 5 --no-table
has "nothing started"
grep -q "started r1 node" "$log" && fail "a child was started"

echo "== 3. a typo in executable: is an error naming the closest built one"
team "$work/exe.yaml" "" "[]" fieldline-launch-test-nod
expect_rc 2 "$work/exe.log" "$bin/fieldline-launch" "$work/exe.yaml" --dry-run
has "exe\.yaml:[0-9]+: process node: executable fieldline-launch-test-nod not found .*\(did you mean fieldline-launch-test-node\?\)"

echo "== 4. the shipped launch files pass --dry-run (every child answers --check-args)"
expect_rc 0 "$work/sim_team.log" "$bin/fieldline-launch" sim_team --dry-run
has "fieldline-teamcomm --robot 6 "
mkfifo "$work/camera.fifo"
expect_rc 0 "$work/real_robot.log" "$bin/fieldline-launch" "$root/config/launch/real_robot.yaml" \
  --dry-run --set camera_device="$work/camera.fifo" --set motor_device=/dev/null
has "^# setting camera_device = $work/camera.fifo \(--set; FIELDLINE_CAMERA_DEVICE or --set"
has "fieldline-camera --robot 1 .* --source v4l2 --input $work/camera.fifo --config robot_640"
echo "   ... and names each missing device with its fix"
expect_rc 2 "$work/real_missing.log" env FIELDLINE_CAMERA_DEVICE=/dev/nosuch-video \
  FIELDLINE_MOTOR_DEVICE=/dev/nosuch-tty "$bin/fieldline-launch" real_robot --dry-run
has "error: r1 camera: arguments rejected \(exit code 2\): camera: /dev/nosuch-video: no such device; list cameras with v4l2-ctl --list-devices"
has "error: r1 motor_bridge: arguments rejected \(exit code 2\): motor_bridge: /dev/nosuch-tty: no such device; .*ls -l /dev/serial/by-id/"
has "2 problem\(s\) in .*real_robot\.yaml: nothing would start"
if [[ ! -e /dev/video0 && ! -e /dev/ttyUSB0 ]]; then
  expect_rc 2 "$work/real_default.log" "$bin/fieldline-launch" "$root/config/launch/real_robot.yaml" --dry-run
  has "camera: /dev/video0: no such device"
  has "motor_bridge: /dev/ttyUSB0: no such device"
fi
expect_rc 2 "$work/bridge_nosuch.log" "$bin/fieldline-motor-bridge" --check-args --device /dev/nosuch
has "motor_bridge: /dev/nosuch: no such device"
expect_rc 2 "$work/camera_nosuch.log" "$bin/fieldline-camera" --source v4l2 --input /dev/nosuch --check-args
has "camera: /dev/nosuch: no such device; list cameras"

echo "== 5. a crash loop is FAILED and makes the exit code 1, also with --duration"
team "$work/loop.yaml" "" "[--feild, msl]"
expect_rc 1 "$work/loop.log" "$bin/fieldline-launch" "$work/loop.yaml" --skip-check-args \
  --duration 60 --no-table --status-period 1
has "r1 node FAILED: crash loop: ended 4 times within 30 s, last: exit code 2"
has "final: .*r1 node failed"
has "done: a process failed"

echo "== 6. exit code 2 for bad arguments; colour table presets checked on read"
expect_rc 2 "$work/fps.log" "$bin/fieldline-camera" --fps 1000 --check-args
sed 's/^colour_table: colours_sim$/colour_table: colours_nope/' "$root/config/camera/omni_sim.yaml" \
  >"$work/nope_camera.yaml"
grep -q "colours_nope" "$work/nope_camera.yaml" || fail "omni_sim.yaml has no colour_table line"
expect_rc 2 "$work/nope.log" "$bin/fieldline-camera" --config "$work/nope_camera.yaml" --check-args
has "colour_table: colour table preset 'colours_nope' does not load"
expect_rc 0 "$work/ok.log" "$bin/fieldline-camera" --check-args

echo "PASS"
