#!/bin/bash
# The camera's CPU time over 20 s with its robot bus at ttl TTL (1: the frames go through a second,
# ttl-0 socket; docs/launch.md "Watching from a laptop"). Not a ctest: a measurement.
#   unshare -n tests/integration/laptop/camera_cpu.sh BUILD/bin TTL
set -u
bin=$1
set -- "$2"
ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
pty=$(mktemp -d)
sim='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304'
robot="udpm://239.255.76.67:7668?ttl=$1&recv_buf_size=4194304"
$bin/fieldline-world-sim --robot 0 --bus-url "$sim" --sim-bus-url "$sim" --scenario default --pty-dir "$pty" > /dev/null 2>&1 &
w=$!
sleep 2
$bin/fieldline-camera --source sim --robot 1 --bus-url "$robot" --sim-bus-url "$sim" --config omni_sim_640 --field msl --preview-rate 2 > /dev/null 2>&1 &
c=$!
sleep 5
a=$(awk '{print $14+$15}' /proc/$c/stat)
sleep 20
b=$(awk '{print $14+$15}' /proc/$c/stat)
echo "ttl $1: camera $(( b - a )) CPU ticks in 20 s ($(getconf CLK_TCK) a second)"
kill $c $w; wait
rm -rf "$pty"
