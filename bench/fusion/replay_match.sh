#!/usr/bin/env bash
# Replays a recording of record_match.sh through fusion, robot by robot, with a settings file,
# and scores the result (docs/log/2026-12-02-fusion.md, "Third round"): prints fieldline-eval's
# summary line.
#
#   bench/fusion/replay_match.sh BIN_DIR REC OUT [FUSION_CONFIG] [REPLAY_ARGS...]
#   bench/fusion/replay_match.sh build/bin /tmp/rec /tmp/rep default
set -eu
bin=$(realpath "${1:?usage: replay_match.sh BIN_DIR REC OUT [FUSION_CONFIG] [REPLAY_ARGS...]}")
rec=$(realpath "${2:?REC}")
out=$(realpath -m "${3:?OUT}")
config=${4:-default}
shift $(($# < 4 ? $# : 4))
mkdir -p "$out"
for n in 1 2 3 4 5 6; do
  [ -s "$rec/robot$n.lcm" ] || continue
  "$bin/fieldline-replay" "$rec/robot$n.lcm" --run fusion --truth "$rec/sim.lcm" \
    --out "$out/r$n.lcm" --fusion-config "$config" "$@" > "$out/replay$n.txt"
done
cat "$out"/r?.lcm > "$out/all.lcm"
"$bin/fieldline-eval" --log "$out/all.lcm" --out "$out/eval" | tail -1
