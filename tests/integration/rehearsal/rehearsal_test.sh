#!/usr/bin/env bash
# real_robot_rehearsal: config/launch/real_robot.yaml, unchanged but for its two device paths
# (given in the environment: FIELDLINE_CAMERA_DEVICE, FIELDLINE_MOTOR_DEVICE), runs against
# simulated devices in a private network namespace, and the robot must localize.
#
#   world_sim          the simulator, outside the real launch: the truth (SIM_WORLD) and the
#                      firmware emulator on a pseudo-terminal, the robot's motor controller
#   fieldline-camera --source sim --to-pipe
#                      the simulator's camera renders what the robot sees from SIM_WORLD and
#                      delivers it into a named pipe 60 ms after exposure, as a camera delivers
#                      to its driver; the launch's camera reads the pipe where it would read
#                      /dev/video0 (YUV4MPEG2)
#   fieldline-launch real_robot
#                      camera, region tracking, feature recognition, fusion, team link, motor bridge
#                      on the pseudo-terminal, and a pilot that holds still
#   fieldline-pilot --steer truth --scenario rehearsal.yaml
#                      stands in for the team's behaviour module: MOTION_COMMAND on the robot's
#                      bus, a figure eight at 0.8 m/s
#   fieldline-rehearsal-probe
#                      TRACKING within 5 s of the first VISION_LINES, mean position error at most
#                      5 cm over one lap of the figure eight (23 s) against the truth; prints both
#
# The window (WINDOW_S, 23 s; 30 s before issue 33): one whole lap of rehearsal.yaml's figure eight
# (18.29 m of path, the lemniscate 6 x 3 m, at 0.8 m/s: 22.9 s), from wherever the robot is at its
# first TRACKING, so the mean covers every place and heading of the path once, both lobes and the
# crossing (the error is not even along it: p99 15 cm against a mean of 1 cm in docs/launch.md's
# run). About 2,450 states (fusion publishes at about 110 Hz here), against 3,200 in 30 s: the mean
# of 0.6-1.1 cm is measured to well under a millimetre either way, and a robot that does not
# localize (what the test is for: a launch file or camera preset that does not fit the robot) is
# off by far more than the 5 cm allowed.
#
# Usage: rehearsal_test.sh BUILD/bin SOURCE_ROOT
set -u
bin=$1
root=$2
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
[ -n "${KEEP:-}" ] && echo "work: $work" || trap 'rm -rf "$work"' EXIT
export FIELDLINE_ROOT="$root"

# Private network and mount namespaces: its own buses and its own /tmp/fieldline (the
# simulator's serial lines and snapshot, fusion's pose files), not a running demo's.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
$ns bash -c "
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
  sim='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304'
  robot='udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304'
  mkfifo '$work/camera.fifo'
  '$bin/fieldline-world-sim' --robot 0 --bus-url \"\$sim\" --sim-bus-url \"\$sim\" \
    --scenario '$here/rehearsal.yaml' --pty-dir '$work/pty' > '$work/world_sim.log' 2>&1 &
  pids=\$!
  '$bin/fieldline-camera' --source sim --robot 1 --bus-url \"\$sim\" --sim-bus-url \"\$sim\" \
    --config omni_sim_640 --field msl --to-pipe '$work/camera.fifo' > '$work/renderer.log' 2>&1 &
  pids=\"\$pids \$!\"
  for i in \$(seq 100); do [ -e '$work/pty/robot1.tty' ] && break; sleep 0.1; done
  # The real launch file; only the device paths differ (docs/launch.md, the rehearsal).
  FIELDLINE_CAMERA_DEVICE='$work/camera.fifo' FIELDLINE_MOTOR_DEVICE='$work/pty/robot1.tty' \
    '$bin/fieldline-launch' real_robot --duration 150 --no-table --status-period 5 \
    > '$work/launch.log' 2>&1 &
  launcher=\$!
  '$bin/fieldline-pilot' --robot 1 --bus-url \"\$robot\" --sim-bus-url \"\$sim\" --steer truth \
    --scenario '$here/rehearsal.yaml' > '$work/behaviour.log' 2>&1 &
  pids=\"\$pids \$!\"
  '$bin/fieldline-rehearsal-probe' --robot 1 --bus-url \"\$robot\" --sim-bus-url \"\$sim\" \
    --window ${WINDOW_S:-23} --tracking-within 5 --max-mean-cm 5 --timeout ${TIMEOUT_S:-120} > '$work/probe.txt' 2> '$work/probe.log'
  echo \$? > '$work/probe.rc'
  kill -TERM \$launcher; wait \$launcher; echo \$? > '$work/launch.rc'
  kill -TERM \$pids; wait
"
echo "--- launcher (first and last lines)"
head -n 3 "$work/launch.log" | cut -c1-300
grep -E "status:|error|warn" "$work/launch.log" | tail -n 4 | cut -c1-600
echo "--- probe"
cat "$work/probe.log" "$work/probe.txt"
fail=0
if [ "$(cat "$work/probe.rc")" != 0 ]; then
  echo "FAIL: the robot did not localize as required"
  for f in world_sim renderer behaviour launch; do echo "--- $f.log"; tail -n 15 "$work/$f.log"; done
  fail=1
fi
# The launch ran the real file's processes, the pilot held still (its note), the camera read the pipe.
for process in camera region_tracking feature_recognition fusion teamcomm motor_bridge pilot; do
  grep -q "r1 $process" "$work/launch.log" || { echo "FAIL: no r1 $process in the launch"; fail=1; }
done
grep -q "holding still" "$work/launch.log" || { echo "FAIL: the launch's pilot did not hold still"; fail=1; }
grep -q "camera.fifo (YUV4MPEG2 pipe" "$work/launch.log" || {
  echo "FAIL: the launch's camera did not read the pipe"; fail=1; }
[ "$fail" = 0 ] && echo "PASS"
exit "$fail"
