#!/usr/bin/env bash
# A recording in the viewer, in Debian's headless chromium (docs/viewer.md, "Watching a
# recording"): 12 s of three robots of the simulated team (their clock offsets on) recorded with
# fieldline-record --team in a private network namespace, then played with fieldline-viewer --log.
# check_playback.py scrubs the page's timeline to a chosen time and checks that the robots drawn
# are exactly the ROBOT_STATE each robot's recording holds as last received by that time, and that
# the error-against-truth plot has points for every robot. Skips (exit 77) without chromium.
#
#   playback_browser_test.sh BIN_DIR [SCREENSHOT.png] [SHARE]  # e.g. docs/images/viewer_playback.png
#
# With SHARE (ctest's way: "" for the screenshot) no team is started here: the recording is the
# six-robot one fusion_test.sh made in SHARE/rec (the fixture team_recording,
# tests/integration/viewer/CMakeLists.txt), every one of its robots checked.
set -u
bin=$(realpath "$1")
screenshot=${2:-}
share=${3:-}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
chromium=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$chromium" ]; then
  echo "SKIP: chromium is not installed (scripts/setup installs Debian's chromium)"
  exit 77
fi
out=$(mktemp -d)
viewer=""
trap '[ -n "$viewer" ] && kill "$viewer" 2> /dev/null; rm -rf "$out"' EXIT
[ -n "$screenshot" ] && screenshot=$(realpath -m "$screenshot")
export FIELDLINE_ROOT="$root"
robots="1 2 3"
if [ -n "$share" ]; then
  if [ ! -d "$share/rec" ]; then
    echo "FAIL: no recording in $share/rec (made by fusion_test.sh)"; exit 1
  fi
  ln -s "$(realpath "$share/rec")" "$out/rec"
  cat "$share/live/record.log" 2> /dev/null | grep -v '^\[' | tail -n 4
  robots=$(ls "$out/rec/" | sed -n 's/^robot\([0-9]\)\.lcm$/\1/p' | tr '\n' ' ')
else
  # Private network and mount namespaces: its own buses and its own /tmp/fieldline.
  ns="unshare -n -m --propagation private"
  $ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
  $ns bash -c "
    ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
    mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline || { echo \"FAIL: cannot mount a private /tmp/fieldline\"; exit 1; }
    export FIELDLINE_CLOCK_REFERENCE_US=\$(date +%s%6N)
    '$bin/fieldline-record' --team --robots 1,2,3 -o '$out/rec' > '$out/record.log' 2>&1 &
    recorder=\$!
    '$bin/fieldline-launch' sim_team --robots 3 --duration 12 --no-table > '$out/launch.log' 2>&1
    kill -INT \$recorder; wait \$recorder
  "
  cat "$out/record.log" | grep -v '^\[' | tail -n 4
fi
for r in $robots; do
  "$bin/fieldline-bus-dump" --log "$out/rec/robot$r.lcm" --channel ROBOT_STATE \
      > "$out/robot$r.jsonl" 2> /dev/null
done
"$bin/fieldline-viewer" --log "$out/rec" --port 0 > "$out/viewer.log" 2>&1 &
viewer=$!
port=""
for _ in $(seq 1 100); do
  port=$(sed -n 's|.*serving http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$out/viewer.log" | head -n 1)
  [ -n "$port" ] && break
  sleep 0.2
done
if [ -z "$port" ]; then
  echo "FAIL: the viewer did not start"; cat "$out/viewer.log"; exit 1
fi
grep 'recording' "$out/viewer.log" | head -n 1
timeout 100 python3 "$here/check_playback.py" "$chromium" "$port" "$out" "$screenshot" \
    $(for r in $robots; do echo "$out/robot$r.jsonl"; done)
