#!/usr/bin/env bash
# laptop_viewer_namespaces: watching robots from a laptop. Two robots, each in its own network
# namespace (a machine of its own), and a laptop in a third, joined by veth pairs to a bridge (the
# team's access point; tests/integration/lib/team_net.sh). Each robot runs the real launch file
# (config/launch/real_robot.yaml as robot 1 and robot 2) with the documented setting for watching
# from another machine, `--bus-ttl 1 --bus-interface eth0`, against simulated devices as in the
# rehearsal (its own simulator, renderer into a named pipe, stand-in behaviour module). The
# laptop runs fieldline-viewer --no-sim --robots 1,2 and fieldline-bus-stats (what lcm-spy
# sees). It must see both robots' buses: ROBOT_STATE, TEAM_STATE, every process's
# SERVICE_STATUS, the camera view from the reduced CAMERA_PREVIEW, and no CAMERA_IMAGE: the
# frames stay on each robot.
#
# In a private mount namespace with its own /tmp/fieldline (the robots' fusion writes its pose file
# there by default): `ip netns exec` copies it into each machine's namespace, so the robots share
# it with each other as before, never with a demo running on the host.
#
# Usage: laptop_test.sh BUILD/bin SOURCE_ROOT
set -u
if [ -z "${FIELDLINE_PRIVATE_MNT:-}" ]; then
  export FIELDLINE_PRIVATE_MNT=1
  exec unshare -m --propagation private bash "$0" "$@"
fi
mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline ||
  { echo "FAIL: cannot mount a private /tmp/fieldline"; exit 1; }
source "$(dirname "$0")/../lib/team_net.sh"
bin=$1
root=$2
here=$(cd "$(dirname "$0")" && pwd)
out=$(mktemp -d)
tag=lv$$
ap=${tag}ap
laptop=${tag}pc
robots="1 2"
cleanup() {
  team_net_remove $laptop $(for r in $robots; do echo ${tag}r$r; done) $ap
  rm -rf "$out"
}
trap cleanup EXIT
export FIELDLINE_ROOT="$root"

team_net_bridge $ap || exit 1
for ns in $(for r in $robots; do echo ${tag}r$r; done) $laptop; do
  case $ns in *pc) address=10.20.0.50;; *) address=10.20.0.${ns##*r};; esac
  team_net_join $ns $address $ap
  # Multicast leaves through the network card (team_net_join routes it to the loopback): the
  # route the launch file's bus.interface names. Local receivers still get their own host's
  # packets (LCM turns multicast loopback on).
  ip -n $ns route replace 224.0.0.0/4 dev eth0
done

for r in $robots; do
  ns=${tag}r$r
  dir="$out/r$r"
  mkdir -p "$dir"
  mkfifo "$dir/camera.fifo"
  sim='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304'
  robot_bus="udpm://239.255.76.67:$((7667 + r))?ttl=0&recv_buf_size=4194304"
  ip netns exec $ns "$bin/fieldline-world-sim" --robot 0 --bus-url "$sim" --sim-bus-url "$sim" \
    --scenario default --pty-dir "$dir/pty" > "$dir/world_sim.log" 2>&1 &
  ip netns exec $ns "$bin/fieldline-camera" --source sim --robot $r --bus-url "$sim" \
    --sim-bus-url "$sim" --config omni_sim_640 --field msl --to-pipe "$dir/camera.fifo" \
    > "$dir/renderer.log" 2>&1 &
  for i in $(seq 100); do [ -e "$dir/pty/robot$r.tty" ] && break; sleep 0.1; done
  ip netns exec $ns env FIELDLINE_CAMERA_DEVICE="$dir/camera.fifo" \
    FIELDLINE_MOTOR_DEVICE="$dir/pty/robot$r.tty" \
    "$bin/fieldline-launch" real_robot --robot $r --bus-ttl 1 --bus-interface eth0 \
    --duration 120 --no-table --status-period 5 > "$dir/launch.log" 2>&1 &
  ip netns exec $ns "$bin/fieldline-pilot" --robot $r --bus-url "$robot_bus" --sim-bus-url "$sim" \
    --steer truth --scenario default > "$dir/behaviour.log" 2>&1 &
done

# The launcher refuses buses meant for another machine that would leave through the wrong
# interface (the route names eth0), with the fix.
refused=0
ns=${tag}r1
ip netns exec $ns env FIELDLINE_CAMERA_DEVICE="$out/r1/camera.fifo" \
  FIELDLINE_MOTOR_DEVICE="$out/r1/pty/robot1.tty" \
  "$bin/fieldline-launch" real_robot --robot 1 --bus-ttl 1 --bus-interface lo --dry-run \
  > "$out/wrong_interface.log" 2>&1
wrong_rc=$?
if [ "$wrong_rc" != 2 ] || ! grep -q "bus.interface lo: the kernel sends the bus group 239.255.76.67 through eth0" "$out/wrong_interface.log"; then
  refused=1
fi

port=18090
ip netns exec $laptop "$bin/fieldline-viewer" --no-sim --robots 1,2 --port $port \
  > "$out/viewer.log" 2>&1 &
ip netns exec $laptop timeout 120 python3 "$here/check_laptop.py" $port "$bin" "$out" \
  > "$out/check.log" 2>&1
rc=$?
echo "--- laptop"
cat "$out/check.log"
echo "--- robot 1, --bus-interface lo (the route names eth0): exit code $wrong_rc"
grep "bus.interface" "$out/wrong_interface.log" | cut -c1-300
if [ "$refused" != 0 ]; then
  echo "FAIL: the launcher did not refuse buses that leave through another interface"
  tail -n 5 "$out/wrong_interface.log"
  rc=1
fi
for r in $robots; do
  echo "--- robot $r launcher (last status)"
  grep "status:" "$out/r$r/launch.log" | tail -n 1 | cut -c1-700
  grep -E "buses leave|CAMERA_IMAGE stays" "$out/r$r/launch.log" | head -n 2 | cut -c1-300
done
if [ "$rc" != 0 ]; then
  for r in $robots; do for f in world_sim renderer launch; do
    echo "--- r$r $f.log"; tail -n 12 "$out/r$r/$f.log" | cut -c1-300; done; done
  echo "--- viewer.log"; tail -n 12 "$out/viewer.log"
  echo "FAIL"
  exit 1
fi
echo "PASS"
