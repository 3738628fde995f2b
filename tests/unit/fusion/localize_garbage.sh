#!/bin/sh
# fieldline-localize on garbage: every case must exit with the expected code and say why.
# Usage: localize_garbage.sh PATH/TO/fieldline-localize
set -u
tool=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
failed=0
# expect CODE TEXT -- ARGS...: runs the tool, checks the exit code and that stderr holds TEXT.
expect() {
  code=$1 text=$2
  shift 3
  "$tool" "$@" > "$dir/out" 2> "$dir/err"
  got=$?
  if [ "$got" -ne "$code" ] || ! grep -q -- "$text" "$dir/err"; then
    echo "FAIL: $* -> exit $got (want $code), stderr:"; cat "$dir/err"; failed=1
  else
    echo "ok: $* -> exit $got: $(head -c 160 "$dir/err")"
  fi
}
printf '1.0,0.5\nnan,0.25\n' > "$dir/nan.csv"
printf '1.0,0.5\n1e308,0.25\n' > "$dir/huge.csv"
printf '# nothing\n' > "$dir/empty.csv"
mkdir "$dir/points.csv"
# 300 points uniform within 6 m of the robot: line points of no field.
awk 'BEGIN { srand(300); n = 0; while (n < 300) { x = 12 * rand() - 6; y = 12 * rand() - 6;
  if (x * x + y * y <= 36) { printf "%.4f,%.4f\n", x, y; n++ } } }' > "$dir/random.csv"
expect 2 "x = nan is not a finite number" -- --points "$dir/nan.csv"
expect 2 "x = 1e308 is" -- --points "$dir/huge.csv"
expect 2 "is a directory" -- --points "$dir/points.csv"
expect 2 "no line points" -- --points "$dir/empty.csv"
expect 1 "no pose on the field fits the points" -- --points "$dir/random.csv"
expect 1 "not valid" -- --points "$dir/random.csv" --guess 0,0,0
exit $failed
