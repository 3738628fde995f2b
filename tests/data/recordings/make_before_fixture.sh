#!/usr/bin/env bash
# Records the "before" fixture of the log upgrade test (docs/replay.md, "Old recordings"): robot
# 1's bus (everything but CAMERA_IMAGE) and the simulator's bus for the first SECONDS of the
# simulated team (sim_team.yaml, one robot, its clock offsets on), with lcm-logger exactly as
# `scripts/demo --record` wrote recordings before recordings described themselves: no
# RECORDING_INFO, log times on the recording machine's clock, robot 1's stamps 0.312 s ahead.
#
#   tests/data/recordings/make_before_fixture.sh build/bin OUT_DIR [SECONDS]
#
# The checked-in copy (tests/data/recordings/main_9085e4b/) was made from main at 9085e4b,
# before odometry_t's change of wheel count: it must keep replaying after every message change.
# Do not regenerate it (that would throw away what it proves); make a new one beside it instead.
set -eu
bin=$(realpath "${1:?usage: make_before_fixture.sh BIN_DIR OUT_DIR [SECONDS]}")
out=$(mkdir -p "${2:?usage: make_before_fixture.sh BIN_DIR OUT_DIR [SECONDS]}" && realpath "$2")
seconds=${3:-6}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
# sim_team.yaml without the viewer (nobody watches; it need not be built).
launch="$out/launch.yaml"
awk '/^  - name: viewer/ {skip=1; next} skip && /^  - name:|^[a-z]/ {skip=0} !skip' \
    "$root/config/launch/sim_team.yaml" > "$launch"
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
$ns bash -c "
  set -eu
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  export FIELDLINE_ROOT='$root'
  LCM_DEFAULT_URL='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304' \
      lcm-logger -q -f '$out/sim.lcm' &
  sim_logger=\$!
  LCM_DEFAULT_URL='udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304' \
      lcm-logger -q -f -v -c CAMERA_IMAGE '$out/robot1.lcm' &
  robot_logger=\$!
  '$bin/fieldline-launch' '$launch' --robots 1 --duration $seconds --no-table > '$out/launch.log' 2>&1 || true
  kill -INT \$sim_logger \$robot_logger; wait \$sim_logger \$robot_logger || true
"
rm -f "$launch"
ls -l "$out"
