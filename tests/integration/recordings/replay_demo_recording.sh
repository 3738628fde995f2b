#!/usr/bin/env bash
# Issue 31's end-to-end check (docs/replay.md, "The demo's recording"): SECONDS (default 20) of
# the six-robot simulated team (sim_team.yaml: every robot on its own clock) evaluated live by
# fieldline-eval while fieldline-record --team records every bus, in a private network namespace
# (or, with --recording SHARE, such a run made by fusion_test.sh: SHARE/rec and its live
# evaluation SHARE/live; ctest's way, tests/integration/recordings/CMakeLists.txt says why). Then
#   1. fusion of every robot replayed from its recording (fieldline-replay --run fusion): exit
#      code 0, under 1 % of the inputs refused, and at least 99 % of the replayed ROBOT_STATE
#      within 1 cm and 0.5 degrees of what the live fusion published at the same stamp (the
#      recording's own ROBOT_STATE: a busy machine delays the live run, not the comparison);
#   2. fieldline-eval --log of the recording: pos_mean within 10 % of the live evaluation's.
#
#   replay_demo_recording.sh BIN_DIR [SECONDS]
#   replay_demo_recording.sh BIN_DIR --recording SHARE
set -u
bin=$(realpath "${1:?usage: replay_demo_recording.sh BIN_DIR [SECONDS | --recording SHARE]}")
seconds=${2:-20}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
export FIELDLINE_ROOT="$root"
if [ "$seconds" = "--recording" ]; then
  share=$(realpath "${3:?--recording needs a directory}")
  if [ ! -f "$share/live/summary.json" ] || [ ! -d "$share/rec" ]; then
    echo "FAIL: no recording with its live evaluation in $share (made by fusion_test.sh)"
    exit 1
  fi
  ln -s "$share/rec" "$out/rec"
  ln -s "$share/live" "$out/live"
  cp "$share/live/eval.txt" "$out/live.txt"
  : > "$out/live.err"
else
  # Private network and mount namespaces: its own buses and its own /tmp/fieldline (the
  # simulator's serial lines and snapshot, fusion's pose files), not a running demo's.
  ns="unshare -n -m --propagation private"
  $ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
  $ns bash -c "
    ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
    mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
    '$bin/fieldline-eval' --scenario default --robots 6 --duration $seconds --record '$out/rec' \
        --out '$out/live' > '$out/live.txt' 2> '$out/live.err'
  " || true
fi
echo "--- live evaluation"; cat "$out/live.txt"; tail -n 3 "$out/live.err"
ls -l "$out/rec/" || { cat "$out/live/record.log"; exit 1; }
fail=0
for r in 1 2 3 4 5 6; do
  rc=0
  "$bin/fieldline-replay" "$out/rec/robot$r.lcm" --run fusion --max-refused 0.01 \
      --out "$out/replay$r.lcm" > "$out/replay$r.txt" 2> "$out/replay$r.err" || rc=$?
  echo "--- robot $r replay (exit code $rc)"; grep -v '^\[' "$out/replay$r.txt"
  grep 'FAILED' "$out/replay$r.err"
  [ "$rc" = 0 ] || fail=1
  "$bin/fieldline-bus-dump" --log "$out/rec/robot$r.lcm" --channel ROBOT_STATE \
      > "$out/live$r.jsonl" 2> /dev/null
  "$bin/fieldline-bus-dump" --log "$out/replay$r.lcm" --channel ROBOT_STATE \
      > "$out/replayed$r.jsonl" 2> /dev/null
  python3 "$here/compare_states.py" "$out/live$r.jsonl" "$out/replayed$r.jsonl" \
      --label "robot $r" || fail=1
done
echo "--- evaluation of the recording"
"$bin/fieldline-eval" --log "$out/rec" --out "$out/logeval" > "$out/log.txt" 2> "$out/log.err" \
    || { cat "$out/log.err"; fail=1; }
cat "$out/log.txt"; grep -v 'refused (' "$out/log.err" | tail -n 8
python3 - "$out/live/summary.json" "$out/logeval/summary.json" <<'PY' || fail=1
import json, sys
live = json.load(open(sys.argv[1]))["pos_mean_m"]
log = json.load(open(sys.argv[2]))["pos_mean_m"]
diff = abs(log - live) / live
print(f"pos_mean live {live * 100:.2f} cm, from the recording {log * 100:.2f} cm: {100 * diff:.1f} % apart (at most 10 %)")
sys.exit(0 if diff <= 0.10 else 1)
PY
exit "$fail"
