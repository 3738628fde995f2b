#!/usr/bin/env bash
# Regenerates vision_lines_match_640.lcmlog, the recorded line points of the feature recognition
# benchmark (bench/feature_recognition): VISION_LINES of robot 1 in the match scenario
# (config/scenarios/match.yaml: robot 1 touring the field among teammates, opponents and the
# ball) with the 640x480 camera preset omni_sim_640, recorded with lcm-logger for SECONDS (default
# 4) after the first 4 s, in a private network namespace. Only the simulator, robot 1's camera,
# region tracking, motor bridge and pilot (steering with the simulator's truth) run.
#
#   bench/data/make_vision_lines_log.sh build/bin [SECONDS]
set -eu
bin=$(realpath "${1:?usage: make_vision_lines_log.sh BIN_DIR [SECONDS]}")
seconds=${2:-4}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
out="$here/vision_lines_match_640.lcmlog"
launch=$(mktemp --suffix=.yaml)
trap 'rm -f "$launch"' EXIT
cat > "$launch" <<YAML
defaults:
  robots: 1
  restart: never
  stop_grace_s: 3.0
  bus: {group: 239.255.76.67, base_port: 7667, ttl: 0, recv_buf_size: 4194304}
processes:
  - {name: world_sim, executable: fieldline-world-sim, robots: sim, args: [--scenario, match], main_channel: SIM_WORLD}
  - {name: camera, executable: fieldline-camera, robots: all, args: [--field, msl, --config, omni_sim_640], main_channel: CAMERA_IMAGE}
  - {name: region_tracking, executable: fieldline-region-tracking, robots: all, args: [--camera, omni_sim_640, --lines-every, 1], main_channel: VISION_LINES}
  - {name: motor_bridge, executable: fieldline-motor-bridge, robots: all, main_channel: ODOMETRY}
  - {name: pilot, executable: fieldline-pilot, robots: all, args: [--scenario, match, --steer, truth], main_channel: MOTION_COMMAND}
YAML
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
$ns bash -c "
  set -eu
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-launch' '$launch' --duration $((seconds + 10)) --no-table > /tmp/make_vision_lines_log.launch.txt 2>&1 &
  launcher=\$!
  sleep 4
  LCM_DEFAULT_URL='udpm://239.255.76.67:7668?ttl=0' lcm-logger -q -f -c VISION_LINES '$out' &
  logger=\$!
  sleep $seconds
  kill -INT \$logger; wait \$logger || true
  kill -TERM \$launcher; wait \$launcher || true
"
ls -l "$out"
