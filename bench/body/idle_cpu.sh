#!/bin/sh
# Idle CPU of the motor bridge: world_sim and one bridge, robot standing (no pilot, so no
# commands), in a private network namespace. Prints the bridge's and the simulator's CPU time
# (utime + stime from /proc/PID/stat) over SECONDS of wall time, as a percentage of one core.
#   usage: bench/body/idle_cpu.sh [BIN_DIR] [SECONDS]     (BIN_DIR defaults to build/bin)
# Needs root (or unshare -r) for the namespace. Run it nice on a quiet machine.
set -eu
bin=${1:-build/bin}
seconds=${2:-20}
exec unshare -n sh -eu -c '
ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
bin=$1; seconds=$2
dir=$(mktemp -d)
"$bin/fieldline-world-sim" --pty-dir "$dir" --log-level warn & sim=$!
sleep 1
"$bin/fieldline-motor-bridge" --robot 1 --device "$dir/robot1.tty" --log-level warn & bridge=$!
sleep 3
ticks() { awk "{print \$14 + \$15}" /proc/$1/stat; }
hz=$(getconf CLK_TCK)
b0=$(ticks $bridge); s0=$(ticks $sim)
sleep "$seconds"
b1=$(ticks $bridge); s1=$(ticks $sim)
kill $bridge; wait $bridge || true
kill $sim; wait $sim || true
rm -rf "$dir"
awk -v b=$((b1 - b0)) -v s=$((s1 - s0)) -v hz=$hz -v t=$seconds "BEGIN {
  printf \"motor_bridge cpu_s=%.2f cpu_percent=%.2f\\n\", b / hz, 100 * b / hz / t;
  printf \"world_sim cpu_s=%.2f cpu_percent=%.2f\\n\", s / hz, 100 * s / hz / t }"
' sh "$bin" "$seconds"
