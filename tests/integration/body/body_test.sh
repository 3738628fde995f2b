#!/usr/bin/env bash
# The simulated body end to end, in a private network namespace: world_sim with its firmware
# emulator on a pty, motor_bridge on that pty, pilot driving robot 1; body_probe watches and
# checks (driving 1 m, ODOMETRY at 50 Hz, stop after the pilot dies, reconnect after the serial
# line is pulled). In a private mount namespace too, with its own /tmp/fieldline (lib/private_ns.sh).
# Usage: body_test.sh <bin dir>
set -u
bin=$(cd "$1" && pwd)
. "$(dirname "$0")/../lib/private_ns.sh" "$@"

work=$(mktemp -d /tmp/fieldline-body.XXXXXX)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null; done
  wait 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

"$bin/fieldline-world-sim" --scenario serial_test --pty-dir "$work" --outage 1.0 \
  >"$work/sim.log" 2>&1 &
sim=$!
pids+=("$sim")
"$bin/fieldline-motor-bridge" --robot 1 --device "$work/robot1.tty" >"$work/bridge.log" 2>&1 &
pids+=("$!")
"$bin/fieldline-pilot" --robot 1 --scenario serial_test --steer truth >"$work/pilot.log" 2>&1 &
pilot=$!
pids+=("$pilot")

"$bin/fieldline-body-probe" --pilot-pid "$pilot" --sim-pid "$sim"
rc=$?
if [ $rc -ne 0 ]; then
  for f in sim bridge pilot; do echo "--- $f.log"; tail -20 "$work/$f.log"; done
fi
exit $rc
