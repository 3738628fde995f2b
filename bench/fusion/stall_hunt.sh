#!/usr/bin/env bash
# Records matches while the simulator is stopped now and then (a stalled machine: the cameras
# go blind, the serial lines deliver late), until one shows a robot on its symmetric twin
# (wrong_half >= 1), so that fieldline-replay can reproduce it (docs/log/2026-12-03-fusion.md,
# eleventh round, "Caught"). Stops every fieldline-world-sim started from BIN_DIR: run nothing else meanwhile.
#
#   bench/fusion/stall_hunt.sh BIN_DIR OUT [RUNS]
#   bench/fusion/stall_hunt.sh build/bin /tmp/hunt 30
set -u
bin=$(realpath "${1:?usage: stall_hunt.sh BIN_DIR OUT [RUNS]}")
out=$(realpath -m "${2:?OUT}")
runs=${3:-30}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
for i in $(seq 1 "$runs"); do
  rec="$out/r$i"
  "$here/record_match.sh" "$bin" "$rec" 40 match > "$rec.log" 2>&1 &
  recorder=$!
  sleep 5
  for _ in $(seq 1 12); do
    pkill -STOP -f "$bin/fieldline-world-sim"
    sleep "0.$((5 + RANDOM % 4))"
    pkill -CONT -f "$bin/fieldline-world-sim"
    sleep "$((1 + RANDOM % 3)).$((RANDOM % 10))"
  done
  wait "$recorder"
  summary=$(grep -h pos_mean "$rec.log" 2>/dev/null | tail -1)
  echo "run $i/$runs: $summary"
  case "$summary" in
    *wrong_half=0*) ;;
    "") echo "run $i: no summary, see $rec.log" ;;
    *) echo "caught in $rec: bench/fusion/replay_match.sh $bin $rec OUT"; exit 0 ;;
  esac
done
echo "not caught in $runs runs"
exit 1
