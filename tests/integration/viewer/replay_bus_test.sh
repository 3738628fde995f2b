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
FIELDLINE_ROOT="$root" $ns bash -c "
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  for mode in live --replay-bus; do
    flag=\$([ \$mode = live ] || echo --replay-bus)
    '$viewer' --no-sim --robots 1 --port 8099 \$flag > '$out/viewer_'\$mode.log 2>&1 &
    v=\$!
    get() { python3 -c \"import sys, urllib.request; sys.stdout.write(urllib.request.urlopen('http://127.0.0.1:8099/' + sys.argv[1], timeout=5).read().decode())\" \"\$1\"; }
    for i in \$(seq 50); do get '' > /dev/null 2>&1 && break; sleep 0.1; done
    lcm-logplayer -l 'udpm://239.255.76.67:7668?ttl=0' '$root/tests/data/recordings/main_9085e4b/robot1.lcm' \
        > /dev/null 2>&1 &
    p=\$!
    sleep 2.5
    get state.json > '$out/state_'\$mode.json
    kill \$p \$v; wait \$v
  done
"
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
