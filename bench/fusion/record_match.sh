#!/usr/bin/env bash
# Records a live match for replays (docs/log/2026-12-02-fusion.md, "Third round": record once,
# replay many times): the simulated team runs `fieldline-eval --scenario SCENARIO --duration S` with a copy of
# sim_team.yaml without its robot clocks (replays and eval --log take every clock as the
# simulator's) and the viewer, the team under nice -n -10, while one lcm-logger per bus writes
# OUT/sim.lcm (SIM_WORLD) and OUT/robotN.lcm (ODOMETRY, VISION_LINES, FIELD_FEATURES,
# VISION_BALL, VISION_OBSTACLES, TEAM_STATE, MOTION_COMMAND, ROBOT_STATE, BALL_STATE). Since the
# twelfth round teamcomm runs too (fusion takes teammates' balls from TEAM_STATE); NO_TEAMCOMM=1
# leaves it out as before. The live run's
# summary is in OUT/live/. Runs in a private network namespace (unshare -n, or -rn without root).
#
#   bench/fusion/record_match.sh BIN_DIR OUT [SECONDS] [SCENARIO] [REGION_TRACKING_ARGS...]
#   bench/fusion/record_match.sh build/bin /tmp/rec 40 match --lines-every 1
set -eu
bin=$(realpath "${1:?usage: record_match.sh BIN_DIR OUT [SECONDS] [SCENARIO] [REGION_TRACKING_ARGS...]}")
out=$(realpath -m "${2:?OUT}")
seconds=${3:-40}
scenario=${4:-match}
shift $(($# < 4 ? $# : 4))
root=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$out"
launch="$out/launch.yaml"
# No robot clocks, no viewer (nor teamcomm with NO_TEAMCOMM=1: the included process is left out
# with `enabled: false`); region tracking's extra arguments, if given, are added to the included
# process's.
awk '
  /^robots:/ { exit }
  /^  - name: viewer$/ { skip = 1; next }
  /^  - name: / { skip = 0 }
  skip { next }
  { print }' "$root/config/launch/sim_team.yaml" > "$launch"
if [ "${NO_TEAMCOMM:-0}" = 1 ]; then
  printf '  - name: teamcomm\n    enabled: false\n' >> "$launch"
fi
if [ $# -gt 0 ]; then
  extra=$(printf '"%s", ' "$@")
  printf '  - name: region_tracking\n    args: [%s]\n' "${extra%, }" >> "$launch"
fi
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
$ns bash -c "
  set -eu
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  export FIELDLINE_ROOT='$root'
  url() { echo \"udpm://239.255.76.67:\$1?ttl=0&recv_buf_size=4194304\"; }
  pids=()
  lcm-logger -q -f -c 'SIM_WORLD' --lcm-url=\"\$(url 7667)\" '$out/sim.lcm' & pids+=(\$!)
  for n in 1 2 3 4 5 6; do
    lcm-logger -q -f -c 'ODOMETRY|VISION_LINES|FIELD_FEATURES|VISION_BALL|VISION_OBSTACLES|TEAM_STATE|MOTION_COMMAND|ROBOT_STATE|BALL_STATE' \
      --lcm-url=\"\$(url \$((7667 + n)))\" '$out/robot'\$n'.lcm' & pids+=(\$!)
  done
  sleep 0.5
  nice -n -10 '$bin/fieldline-eval' --scenario '$scenario' --duration '$seconds' --launch '$launch' \
    --out '$out/live' | grep -E 'pos_mean|team_ball_mean' || true
  for p in \"\${pids[@]}\"; do kill -INT \$p; done
  wait || true
"
ls -l "$out"
