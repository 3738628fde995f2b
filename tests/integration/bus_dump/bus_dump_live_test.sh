#!/bin/sh
# fieldline-bus-dump on a live bus: lcm-logplayer plays the fixture log (write_fixture.cpp) onto
# a bus in a private network namespace (and mount namespace, with its own /tmp/fieldline); the
# dump prints every good message with its receive time and reports the garbage and NaN events.
# usage: bus_dump_live_test.sh FIELDLINE_BUS_DUMP WRITE_FIXTURE CHECK_PY
set -eu
dump=$1
write_fixture=$2
check=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$write_fixture" "$dir/fixture.lcmlog"
"$write_fixture" "$dir/probe.lcmlog" --probe

ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
$ns sh -c "
  set -eu
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  url='udpm://239.255.76.67:7667?ttl=0'
  '$dump' --url \"\$url\" --follow >'$dir/out.jsonl' 2>'$dir/err.txt' &
  pid=\$!
  # Probe until the dump prints one: then it is listening and the fixture is played once.
  for attempt in \$(seq 100); do
    lcm-logplayer -l \"\$url\" '$dir/probe.lcmlog' >/dev/null 2>&1
    sleep 0.2
    [ -s '$dir/out.jsonl' ] && break
  done
  lcm-logplayer -l \"\$url\" '$dir/fixture.lcmlog' >/dev/null 2>&1
  for attempt in \$(seq 300); do
    [ \$(grep -vc '\"seq\":1000,' '$dir/out.jsonl') -ge 13 ] && break
    sleep 0.1
  done
  kill -INT \$pid
  wait \$pid
"
cat "$dir/err.txt"
python3 "$check" "$dir/out.jsonl" --live
grep -q 'rejected ODOMETRY: .*(decode)' "$dir/err.txt" || { echo "FAIL: garbage not reported"; exit 1; }
grep -q 'rejected ROBOT_STATE: .*x is not finite' "$dir/err.txt" || { echo "FAIL: NaN not reported"; exit 1; }
echo PASS
