#!/usr/bin/env bash
# fieldline-viewer --replay-bus follows a bus that a recording is played onto (lcm-logplayer with
# tests/data/recordings/main_9085e4b/robot1.lcm, recorded on 2026-12-06): its messages are shown,
# not refused as stale, while a live viewer refuses them (docs/viewer.md). In a private network
# namespace.
#
#   replay_bus_test.sh VIEWER
set -u
viewer=$(realpath "$1")
root=$(cd "$(dirname "$0")/../../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
FIELDLINE_ROOT="$root" $ns bash -s "$viewer" "$root" "$out" <<'EOF'
set -u
viewer=$1 root=$2 out=$3
. "$root/tests/integration/lib/wait.sh"
ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
get() {
  python3 -c "import sys, urllib.request; sys.stdout.write(urllib.request.urlopen('http://127.0.0.1:8099/' + sys.argv[1], timeout=5).read().decode())" "$1"
}
# shown: the viewer's state has robot 1's ROBOT_STATE.
shown() {
  get state.json | python3 -c "import json, sys; sys.exit(json.load(sys.stdin)['robots'][0]['robot_state'] is None)"
}
for mode in live --replay-bus; do
  flag=$([ $mode = live ] || echo --replay-bus)
  "$viewer" --no-sim --robots 1 --port 8099 $flag > "$out/viewer_$mode.log" 2>&1 &
  v=$!
  wait_for 30 "the viewer's page" get ''
  lcm-logplayer -l 'udpm://239.255.76.67:7668?ttl=0' "$root/tests/data/recordings/main_9085e4b/robot1.lcm" \
    > /dev/null 2>&1 &
  p=$!
  if [ $mode = live ]; then
    # The live viewer has heard the recording's ROBOT_STATE and refused it as stale.
    wait_for 30 "the live viewer refusing a stale ROBOT_STATE" \
      grep -q "stale .*ROBOT_STATE: utime_published" "$out/viewer_$mode.log"
  else
    wait_for 30 "the replay viewer showing ROBOT_STATE" shown
  fi
  get state.json > "$out/state_$mode.json"
  kill $p $v; wait $v
done
EOF
python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
live = json.load(open(f"{out}/state_live.json"))["robots"][0]["robot_state"]
replay = json.load(open(f"{out}/state_--replay-bus.json"))["robots"][0]["robot_state"]
print("live viewer:", "nothing shown" if live is None else f"seq {live['seq']}")
print("--replay-bus:", "nothing shown" if replay is None else
      f"ROBOT_STATE seq {replay['seq']} at ({replay['x']:.2f}, {replay['y']:.2f})")
sys.exit(0 if live is None and replay is not None and replay["utime"] > 0 else 1)
PY
