#!/usr/bin/env bash
# CPU use of the simulated team per executable, summed over its robots: CPU seconds per second of
# wall time over SECONDS (default 30) after a 10 s warm-up, in private network and mount namespaces.
#
#   bench/team/team_cpu.sh [LAUNCH] [SECONDS] [BIN_DIR]
#   bench/team/team_cpu.sh sim_team 30 build/bin
#
# LAUNCH is a preset name or a launch file (fieldline-launch's argument). CPU time, not wall time,
# so other load on the machine matters less (it still changes caches and scheduling).
# With TEAM_CPU_WAKEUPS=1 each line also gives the executable's wake-ups a second (voluntary context
# switches of its main thread, /proc/PID/status), summed over its robots.
set -eu
launch=${1:-sim_team}
seconds=${2:-30}
bin=$(realpath "${3:-build/bin}")
root=$(cd "$(dirname "$0")/../.." && pwd)
[ -f "$launch" ] && launch=$(realpath "$launch")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# A private mount namespace too: the simulator's pseudo-terminals, its snapshot and fusion's pose
# files live in /tmp/fieldline, which every team on the machine would share otherwise (a second
# team's motor bridges writing into this team's serial lines).
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
$ns bash -c "
  set -eu
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
  export FIELDLINE_ROOT='$root'
  # The launcher's own end is only a safety net (the script stops it after the window): under load
  # its start-up checks and the snapshots took long enough that seconds + 20 ended it first.
  '$bin/fieldline-launch' '$launch' --duration $((seconds + 300)) --no-table > '$work/launch.log' 2>&1 &
  launcher=\$!
  # Every child's executable, pid and CPU ticks (user + system) so far.
  snapshot() {
    for pid in \$(pgrep -P \$launcher); do
      exe=\$(basename \"\$(readlink /proc/\$pid/exe)\" 2>/dev/null) || continue
      ticks=\$(awk '{print \$14 + \$15}' /proc/\$pid/stat 2>/dev/null) || continue
      wakes=\$(awk '/^voluntary_ctxt_switches/{print \$2}' /proc/\$pid/status 2>/dev/null) || continue
      echo \"\$exe \$pid \$ticks \$wakes\"
    done
  }
  sleep 10
  snapshot > '$work/before'
  sleep $seconds
  snapshot > '$work/after'
  if ! kill -0 \$launcher 2>/dev/null; then
    echo 'team_cpu: the launcher ended before the measurement did; its log:' >&2
    tail -20 '$work/launch.log' >&2
    exit 1
  fi
  kill -TERM \$launcher; wait \$launcher || true
"
# Processes present in both snapshots (a restarted one is left out, not misread).
join -j 2 <(sort -k2 "$work/before") <(sort -k2 "$work/after") |
  awk -v s="$seconds" -v hz="$(getconf CLK_TCK)" -v wakes="${TEAM_CPU_WAKEUPS:-0}" '
    # After the join: pid, then executable, ticks and wake-ups before and after.
    { cpu[$2] += ($6 - $3) / hz / s; total += ($6 - $3) / hz / s; wk[$2] += ($7 - $4) / s }
    END {
      for (e in cpu) {
        if (wakes == "1") printf "%-36s %.3f cpu-s/s %8.1f wakeups/s\n", e, cpu[e], wk[e]
        else printf "%-32s %.3f cpu-s/s\n", e, cpu[e]
      }
      printf "%-32s %.3f cpu-s/s\n", "total", total
    }' |
  sort
