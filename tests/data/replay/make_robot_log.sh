#!/usr/bin/env bash
# Regenerates robot1_bus.lcmlog, the fixture of tools/replay's test: everything on robot 1's bus
# except CAMERA_IMAGE (ODOMETRY, VISION_*, FIELD_FEATURES, ROBOT_STATE, ... about 0.7 MB) for
# 10 s of the simulated team (sim_team.yaml, one robot) after its first 3 s, recorded with
# lcm-logger in a private network namespace. The launch file is sim_team.yaml without its
# `robots:` clock section (made when a replay ran on the log's time; it now runs on the robot's
# own clock, docs/replay.md, so a fixture with offsets would replay too: this one keeps the
# simulator's clock so that its stamps compare directly with the truth).
#
#   tests/data/replay/make_robot_log.sh build/bin [SECONDS]
#
# The traffic differs between recordings (the team runs on the wall clock); the test compares two
# replays of whatever this file holds, so a regenerated file needs no other change.
set -eu
bin=$(realpath "${1:?usage: make_robot_log.sh BIN_DIR [SECONDS]}")
seconds=${2:-10}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
out="$here/robot1_bus.lcmlog"
launch=$(mktemp --suffix=.yaml)
trap 'rm -f "$launch"' EXIT
sed '/^robots:/,$d' "$root/config/launch/sim_team.yaml" > "$launch"
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
$ns bash -c "
  set -eu
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-launch' '$launch' --robots 1 --duration $((seconds + 8)) --no-table \
      > /dev/null 2>&1 &
  launcher=\$!
  sleep 3
  LCM_DEFAULT_URL='udpm://239.255.76.67:7668?ttl=0' lcm-logger -q -f -v -c CAMERA_IMAGE '$out' &
  logger=\$!
  sleep $seconds
  kill -INT \$logger; wait \$logger || true
  kill -TERM \$launcher; wait \$launcher || true
"
ls -l "$out"
