#!/usr/bin/env bash
# The viewer in Debian's headless chromium during a short run of the simulated team (six robots,
# sim_team.yaml, in a private network namespace): waits until the page has drawn six robots'
# estimates, then checks that what it drew for robot 3 is a ROBOT_STATE robot 3's fusion
# published, unchanged, and the last one published before the viewer's state document, within
# one viewer frame (50 ms at 20 Hz); and that the camera view of robot 1 shows a frame with as
# many line-point marks as robot 1's VISION_LINES of that frame. Skips (exit 77) without chromium.
#
#   browser_test.sh BIN_DIR [SCREENSHOT.png]     # the screenshot: e.g. docs/images/viewer.png
set -u
bin=$(realpath "$1")
screenshot=${2:-}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
chromium=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$chromium" ]; then
  echo "SKIP: chromium is not installed (scripts/setup installs Debian's chromium)"
  exit 77
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
[ -n "$screenshot" ] && screenshot=$(realpath -m "$screenshot")
# Private network and mount namespaces: its own buses and its own /tmp/fieldline (the
# simulator's serial lines and snapshot, fusion's pose files), not a running demo's.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
$ns bash -c "
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline || { echo \"FAIL: cannot mount a private /tmp/fieldline\"; exit 1; }
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-launch' sim_team --duration 90 --no-table > '$out/launch.log' 2>&1 &
  launcher=\$!
  '$bin/fieldline-bus-dump' --robot 3 --channel ROBOT_STATE --follow > '$out/robot3.jsonl' \
      2> '$out/dump.log' &
  dump=\$!
  '$bin/fieldline-bus-dump' --robot 1 --channel VISION_LINES --follow > '$out/lines1.jsonl' \
      2> '$out/dump_lines.log' &
  dump_lines=\$!
  timeout 100 python3 '$here/check_browser.py' '$chromium' 8080 '$out/robot3.jsonl' \
      '$out/lines1.jsonl' '$out' '$screenshot'
  echo \$? > '$out/check.rc'
  kill \$dump \$dump_lines; kill -TERM \$launcher; wait \$launcher
"
rc=$(cat "$out/check.rc" 2>/dev/null || echo 1)
if [ "$rc" != 0 ]; then
  echo "--- launch log"; tail -n 20 "$out/launch.log" | cut -c1-300
fi
exit "$rc"
