#!/usr/bin/env bash
# fieldline-launch --graph on the shipped launch files: every process with what it reads and
# writes (each process's own --print-io), and every required input has a writer (exit 0). A team
# without fusion, and a robot without its camera, are refused (exit 1) naming the reader and the
# channel nobody writes. Starts no bus: the children only print their declarations.
#
#   graph_test.sh LAUNCH SOURCE_DIR
set -u
launch=$(realpath "$1")
root=$(realpath "$2")
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
export FIELDLINE_ROOT="$root"
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect CODE NAME ARGS...: runs fieldline-launch ARGS --graph into $out/NAME, checks the exit code.
expect() {
  local code=$1 name=$2
  shift 2
  "$launch" "$@" --graph > "$out/$name" 2> "$out/$name.err"
  local rc=$?
  [ $rc = "$code" ] || { fail "$name: exit code $rc, expected $code"; cat "$out/$name.err"; }
}

expect 0 sim_team sim_team
cat "$out/sim_team"
for r in 1 2 3 4 5 6; do
  grep -q "^robot $r bus  udpm://239.255.76.67:$((7667 + r))" "$out/sim_team" || fail "no robot $r bus"
done
for p in world_sim viewer camera region_tracking motor_bridge pilot feature_recognition fusion \
  teamcomm; do
  grep -q "^  $p\$" "$out/sim_team" || fail "sim_team: process $p not shown"
done
# Each robot's pipeline, joined by the declarations: the channel, and where it comes from.
grep -Eq "reads +ODOMETRY +<- motor_bridge\$" "$out/sim_team" || fail "fusion's ODOMETRY"
grep -Eq "reads +SIM_WORLD \(sim bus\) +<- world_sim \(sim\)\$" "$out/sim_team" || fail "SIM_WORLD"
grep -Eq "serial /tmp/fieldline/robot3.tty \(both\) <-> world_sim \(sim\)" "$out/sim_team" ||
  fail "robot 3's serial line to the simulator"
grep -Eq "udp +239.255.76.100:47600 \(both\) <-> teamcomm \(r1, r2, r4-r6\)" "$out/sim_team" ||
  fail "robot 3's team link to the others"
grep -q "Every required input has a writer." "$out/sim_team" || fail "sim_team: a missing writer"

# A real robot: the camera and the motor controller are devices, outside the launch.
expect 0 real_robot real_robot --robot 2
cat "$out/real_robot"
grep -Eq "camera +/dev/video0 \(in\) <-> outside the launch" "$out/real_robot" || fail "the camera"
grep -Eq "serial /dev/ttyUSB0 \(both\) <-> outside the launch" "$out/real_robot" ||
  fail "the motor controller"
grep -q "Every required input has a writer." "$out/real_robot" || fail "real_robot: a missing writer"

# Without fusion nobody writes ROBOT_STATE, which the pilots and the team links need.
python3 - "$root/config/launch/sim_team.yaml" "$out/no_fusion.yaml" "$root" <<'PY'
import sys
text = open(sys.argv[1]).read().replace("include: robot_processes",
                                        f"include: {sys.argv[3]}/config/launch/robot_processes.yaml")
at = text.index("\nrobots:")
open(sys.argv[2], "w").write(text[:at + 1] + "  - name: fusion\n    enabled: false\n" + text[at + 1:])
PY
expect 1 no_fusion "$out/no_fusion.yaml" --robots 2
grep -q "r1 pilot reads ROBOT_STATE on robot 1's bus: no process of the launch writes it" \
  "$out/no_fusion" || { fail "no_fusion: the pilot's ROBOT_STATE not named"; cat "$out/no_fusion"; }
grep -q "r2 teamcomm reads ROBOT_STATE on robot 2's bus" "$out/no_fusion" ||
  fail "no_fusion: teamcomm's ROBOT_STATE not named"

[ $failures = 0 ] && echo PASS
exit $((failures > 0))
