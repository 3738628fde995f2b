#!/usr/bin/env bash
# Every recording kept under tests/data/recordings/ (made by older software, never regenerated)
# replays with today's code: fieldline-replay through feature recognition and fusion exits 0 with
# nothing refused and tracks, fieldline-bus-dump reads every message of a fieldline channel, and
# fieldline-log-upgrade writes a copy in today's types that needs no upgrade any more.
#
#   old_recordings_test.sh BIN_DIR
set -u
bin=$(realpath "${1:?usage: old_recordings_test.sh BIN_DIR}")
root=$(cd "$(dirname "$0")/../../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail=0
for dir in "$root"/tests/data/recordings/*/; do
  name=$(basename "$dir")
  log="$dir/robot1.lcm"
  rc=0
  "$bin/fieldline-replay" "$log" --run feature_recognition,fusion --out "$out/$name.lcm" \
      > "$out/$name.txt" 2> "$out/$name.err" || rc=$?
  echo "--- $name: replay exit code $rc"
  cat "$out/$name.txt"
  grep 'FAILED' "$out/$name.err"
  [ "$rc" = 0 ] || fail=1
  grep -q ' refused 0 ' "$out/$name.txt" || { echo "FAIL: $name: inputs refused"; fail=1; }
  "$bin/fieldline-bus-dump" --log "$log" > /dev/null 2> "$out/$name.dump"
  grep 'bus_dump: [0-9]* messages printed\|upgraded' "$out/$name.dump"
  if grep -q 'rejected [^ ]*: .*(decode)\|(wrong_type)' "$out/$name.dump"; then
    echo "FAIL: $name: messages that do not decode"; fail=1
  fi
  "$bin/fieldline-log-upgrade" "$log" "$out/$name.upgraded.lcm" || fail=1
  "$bin/fieldline-bus-dump" --log "$out/$name.upgraded.lcm" > /dev/null 2> "$out/$name.dump2"
  if grep -q 'upgraded' "$out/$name.dump2"; then
    echo "FAIL: $name: the upgraded copy still needs upgrading"; fail=1
  fi
done
# The one made before the twin flags must have been upgraded, not skipped.
grep -q 'upgraded robot_state_t v1 [1-9]' "$out/main_428ac34.dump" 2> /dev/null ||
  grep -q 'of robot_state_t v1 upgraded' "$out/main_428ac34.dump" ||
  { echo "FAIL: main_428ac34's ROBOT_STATE was not upgraded"; fail=1; }
grep -q 'upgraded.* team_state_t v1 [1-9]' "$out/main_428ac34.txt" ||
  { echo "FAIL: main_428ac34's TEAM_STATE was not upgraded on its way to fusion"; fail=1; }
# Every recording before the four-wheel change holds three-wheel ODOMETRY: upgraded on its way
# to fusion (wheel_count 3).
grep -q 'upgraded.* odometry_t v1 [1-9]' "$out/main_9085e4b.txt" ||
  { echo "FAIL: main_9085e4b's ODOMETRY was not upgraded on its way to fusion"; fail=1; }
exit "$fail"
