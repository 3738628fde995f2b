#!/usr/bin/env bash
# Regenerates camera_robot1.lcmlog, the replay test's recorded traffic: robot 1's CAMERA_IMAGE
# from the simulated team (world_sim, camera, motor_bridge, pilot as scripts/demo runs them), 15
# frames (320x240 YUYV, about 2.3 MB) after the first 90, in a private network namespace.
#
#   tests/data/replay/make_camera_log.sh build/bin
#
# The frames differ from run to run (the team runs on the wall clock); the replay test compares
# two replays of whatever this file holds, so a regenerated file needs no other change.
set -eu
bin=$(realpath "${1:?usage: make_camera_log.sh BIN_DIR}")
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
out="$here/camera_robot1.lcmlog"
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
$ns bash -c "
  set -eu
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-launch' sim_team --robots 1 --duration 30 --no-table > /dev/null 2>&1 &
  launcher=\$!
  '$bin/fieldline-log-record' --robot 1 --channel CAMERA_IMAGE --skip 90 --count 15 \
      --timeout 25 --output '$out'
  kill -TERM \$launcher; wait \$launcher || true
"
ls -l "$out"
