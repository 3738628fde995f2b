#!/usr/bin/env bash
# fieldline-viewer in a private network namespace: a ROBOT_STATE published on robot 3's bus is
# served unchanged in GET /state.json and over the WebSocket (/ws), under robot 3 only; ten
# WebSocket clients at once each get it; POST, PUT, DELETE, PATCH, HEAD and OPTIONS get 405;
# unknown paths 404; the page, its script and the field are served.
set -u
viewer=$1
publisher=$2
here=$(cd "$(dirname "$0")" && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# Private network and mount namespaces: its own buses and its own /tmp/fieldline (the
# simulator's serial lines and snapshot, fusion's pose files), not a running demo's.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
port=18080
$ns bash -c "
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline || { echo \"FAIL: cannot mount a private /tmp/fieldline\"; exit 1; }
  '$viewer' --port $port > '$out/viewer.log' 2>&1 &
  viewer_pid=\$!
  '$publisher' --robot 3 --duration 20 > '$out/published.json' 2> '$out/publisher.log' &
  publisher_pid=\$!
  timeout 30 python3 '$here/check_viewer.py' $port '$out/published.json'
  echo \$? > '$out/check.rc'
  kill \$publisher_pid \$viewer_pid
  wait \$viewer_pid
  echo \$? > '$out/viewer.rc'
"
echo "--- viewer log"; tail -n 5 "$out/viewer.log" | cut -c1-300
echo "--- publisher log"; tail -n 5 "$out/publisher.log" | cut -c1-300
rc=$(cat "$out/check.rc" 2>/dev/null || echo 1)
viewer_rc=$(cat "$out/viewer.rc" 2>/dev/null || echo 1)
if [ "$viewer_rc" != 0 ]; then
  echo "FAIL: viewer exit code $viewer_rc after SIGTERM"
  exit 1
fi
exit "$rc"
