#!/bin/sh
# fieldline-bus-dump on a log written with bus::LogWriter: every message type comes out as the
# expected JSON, bad events are reported on stderr and skipped, a damaged log still dumps, and
# bad arguments exit with 2.
# usage: bus_dump_test.sh FIELDLINE_BUS_DUMP WRITE_FIXTURE CHECK_PY
set -eu
dump=$1
write_fixture=$2
check=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

fail() { echo "FAIL: $*" >&2; exit 1; }

"$write_fixture" "$dir/fixture.lcmlog"

# Every type, every field.
"$dump" --log "$dir/fixture.lcmlog" >"$dir/out.jsonl" 2>"$dir/err.txt" || fail "dump exit $?"
cat "$dir/err.txt"
python3 "$check" "$dir/out.jsonl"
grep -q 'rejected ODOMETRY: event 12 .*(decode)' "$dir/err.txt" || fail "garbage event not reported"
grep -q 'rejected ROBOT_STATE: event 13 .*x is not finite.*(invalid)' "$dir/err.txt" ||
  fail "NaN event not reported"
grep -q '13 messages printed, 2 rejected (decode: 1, invalid: 1)' "$dir/err.txt" ||
  fail "wrong summary"

"$dump" --log "$dir/fixture.lcmlog" --image-data >"$dir/data.jsonl"
python3 "$check" "$dir/data.jsonl" --image-data

# --channel, --count and --duration (log time from the first dumped event).
"$dump" --log "$dir/fixture.lcmlog" --channel ODOMETRY --channel SIM_WORLD >"$dir/some.jsonl"
[ "$(python3 -c 'import json,sys; print(",".join(json.loads(l)["channel"] for l in open(sys.argv[1])))' "$dir/some.jsonl")" = \
  "ODOMETRY,SIM_WORLD,ODOMETRY" ] || fail "--channel"
[ "$("$dump" --log "$dir/fixture.lcmlog" --count 3 | wc -l)" -eq 3 ] || fail "--count"
# Events are 1 ms apart: 2.5 ms from the first takes events 0, 1 and 2.
[ "$("$dump" --log "$dir/fixture.lcmlog" --duration 0.0025 | wc -l)" -eq 3 ] || fail "--duration"

# A log cut inside its last event: everything before it dumps, the rest is reported.
size=$(wc -c <"$dir/fixture.lcmlog")
head -c $((size - 5)) "$dir/fixture.lcmlog" >"$dir/cut.lcmlog"
"$dump" --log "$dir/cut.lcmlog" >"$dir/cut.jsonl" 2>"$dir/cut_err.txt" || fail "cut log exit $?"
[ "$(wc -l <"$dir/cut.jsonl")" -eq 12 ] || fail "cut log: $(wc -l <"$dir/cut.jsonl") messages"
grep -q '(truncated)\|(damaged)' "$dir/cut_err.txt" || fail "cut log damage not reported"

# Bad arguments: exit code 2.
expect2() {
  set +e
  "$dump" "$@" >/dev/null 2>&1
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "exit $rc (not 2) for: $*"
}
expect2 --log "$dir/fixture.lcmlog" --channel NOT_A_CHANNEL
expect2 --log "$dir/missing.lcmlog"
expect2 --log "$dir/fixture.lcmlog" --robot 1
expect2 --log "$dir/fixture.lcmlog" --count 0
expect2 --log "$dir/fixture.lcmlog" --follow
expect2 --robot 7 --count 1
expect2 --robot 1
expect2 --no-such-option
expect2
"$dump" --help >/dev/null || fail "--help"
echo PASS
