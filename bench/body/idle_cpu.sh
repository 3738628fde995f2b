#!/bin/sh
# Idle CPU of the motor bridge: world_sim and one bridge, robot standing (no pilot, so no
# commands), in a private network namespace. Prints the bridge's and the simulator's CPU time
# (utime + stime from /proc/PID/stat) over SECONDS of wall time, as a percentage of one core,
# and their wake-ups per second (voluntary context switches, /proc/PID/status): the CPU share
# depends on the machine's load, the wake-ups much less.
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
wakeups() { awk "/^voluntary_ctxt_switches/ {print \$2}" /proc/$1/status; }
hz=$(getconf CLK_TCK)
b0=$(ticks $bridge); s0=$(ticks $sim); bw0=$(wakeups $bridge); sw0=$(wakeups $sim)
sleep "$seconds"
b1=$(ticks $bridge); s1=$(ticks $sim); bw1=$(wakeups $bridge); sw1=$(wakeups $sim)
kill $bridge; wait $bridge || true
kill $sim; wait $sim || true
rm -rf "$dir"
awk -v b=$((b1 - b0)) -v s=$((s1 - s0)) -v bw=$((bw1 - bw0)) -v sw=$((sw1 - sw0)) \
    -v hz=$hz -v t=$seconds "BEGIN {
  printf \"motor_bridge cpu_s=%.2f cpu_percent=%.2f wakeups_per_s=%.0f\\n\", b / hz, 100 * b / hz / t, bw / t;
  printf \"world_sim cpu_s=%.2f cpu_percent=%.2f wakeups_per_s=%.0f\\n\", s / hz, 100 * s / hz / t, sw / t }"
' sh "$bin" "$seconds"
