#!/usr/bin/env bash
# Where the named executables' time goes in the running simulated team: user against system CPU
# per message, wake-ups, and a perf profile (kernel and user) sorted into what the time went to
# (the algorithm, the bus's own code, each system call, wake-ups).
#
#   bench/team/team_profile.sh BIN_DIR OUT SECONDS EXE...
#   bench/team/team_profile.sh build/bin /tmp/prof 20 region-tracking motor-bridge feature-recognition
#
# As team_cpu.sh: sim_team in private network and mount namespaces, 10 s warm-up; then SECONDS of
# `perf record -F 999 -g` of every robot's process of each EXE (kernel samples need root or
# perf_event_paranoid <= 1), with /proc/PID/stat utime and stime and the voluntary context
# switches before and after. Per message: 30 a second for camera, region tracking and feature
# recognition, 50 for pilot and motor bridge. Writes OUT/EXE.perf.data and OUT/EXE.txt (the
# sorted shares, bench/team/perf_categories.py) and prints the summary. Hold the live lock
# around it on a shared machine (one team at a time).
set -eu
if [ $# -lt 4 ]; then
  sed -n '2,15p' "$0" >&2
  exit 2
fi
bin=$(realpath "$1") out=$(realpath -m "$2") seconds=$3
shift 3
exes="$*"
root=$(cd "$(dirname "$0")/../.." && pwd)
rm -f "$out/before" "$out/after"
mkdir -p "$out"
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
$ns bash -c "
  set -eu
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-launch' sim_team --duration $((seconds + 300)) --no-table > '$out/launch.log' 2>&1 &
  launcher=\$!
  sleep 10
  # Per process: executable, pid, user and system ticks, voluntary context switches.
  snapshot() {
    for exe in $exes; do
      for p in \$(pgrep -P \$launcher); do
        [ \"\$(basename \"\$(readlink /proc/\$p/exe)\")\" = fieldline-\$exe ] || continue
        echo \"\$exe \$p \$(awk '{print \$14, \$15}' /proc/\$p/stat) \$(awk '/^voluntary_ctxt_switches/{print \$2}' /proc/\$p/status)\"
      done
    done
  }
  snapshot > '$out/before'
  perfs=()
  for exe in $exes; do
    pids=\$(awk -v e=\$exe '\$1 == e {print \$2}' '$out/before' | paste -sd,)
    [ -n \"\$pids\" ] || { echo \"team_profile: no fieldline-\$exe running\" >&2; exit 1; }
    perf record -q -F 999 -g -p \$pids -o '$out/'\$exe.perf.data -- sleep $seconds > /dev/null &
    perfs+=(\$!)
  done
  wait \${perfs[@]}
  snapshot > '$out/after'
  kill -TERM \$launcher; wait \$launcher || true
"
for exe in $exes; do
  python3 "$root/bench/team/perf_categories.py" "$out/$exe.perf.data" > "$out/$exe.txt"
done
echo "$(date -u +%T) load $(cut -d' ' -f1-3 /proc/loadavg); per process of each executable (its robots' mean):"
# join needs both sides sorted on the pid field alone, bytewise (a locale's order drops rows).
LC_ALL=C join -j 2 <(LC_ALL=C sort -k2,2 "$out/before") <(LC_ALL=C sort -k2,2 "$out/after") |
  awk -v s="$seconds" -v hz="$(getconf CLK_TCK)" '
    # After the join: pid, then executable, user, system, wake-ups before and after.
    { n[$2]++; u[$2] += ($7 - $3) / hz / s; k[$2] += ($8 - $4) / hz / s; w[$2] += ($9 - $5) / s }
    END {
      for (e in n) {
        rate = (e ~ /camera|region|feature/) ? 30 : (e ~ /pilot|motor/) ? 50 : 0
        printf "%-20s user %.4f sys %.4f CPU-s/s", e, u[e] / n[e], k[e] / n[e]
        if (rate) printf ", per message user %.3f sys %.3f ms", u[e] / n[e] / rate * 1000, k[e] / n[e] / rate * 1000
        printf ", wake-ups %.1f/s\n", w[e] / n[e]
      }
    }' | sort
for exe in $exes; do
  echo "== $exe (share of its perf samples; OUT/$exe.txt)"
  head -14 "$out/$exe.txt"
done
