#!/usr/bin/env bash
# Generates the systemd units of sim_team.yaml (six robots and the simulator) and real_robot.yaml
# with fieldline-systemd-units and checks every target instance and every service instance with
# `systemd-analyze verify`: exit code 0 and not one line of complaint. A deliberately broken copy
# must draw a complaint (the check has teeth). Skips (77) without systemd-analyze.
set -u
generator=$1
bin_dir=$(realpath "$2")
if ! command -v systemd-analyze > /dev/null; then
  echo "SKIP: systemd-analyze is not installed (Debian package systemd, in scripts/setup)"
  exit 77
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail=0

verify() {  # DIR: the simulator's target, robot N's target for each robot<N>.env, what they want
  local dir=$1 units="" robots r
  if [ -f "$dir/fieldline-sim.target" ]; then
    units="fieldline-sim.target $(sed -n 's/^Wants=\(.*\)$/\1/p' "$dir/fieldline-sim.target")"
  fi
  robots=$(cd "$dir" && ls robot*.env | sed -n 's/^robot\([1-9][0-9]*\)\.env$/\1/p')
  for r in $robots; do
    units="$units fieldline-robot@$r.target"
    units="$units $(sed -n 's/^Wants=\(.*\)$/\1/p' "$dir/fieldline-robot@.target" | sed "s/%i/$r/")"
  done
  [ -f "$dir/fieldline-bus-route.service" ] && units="$units fieldline-bus-route.service"
  (cd "$dir" && SYSTEMD_UNIT_PATH="$dir:" systemd-analyze verify --man=no $units) \
      > "$dir.verify" 2>&1
  local rc=$?
  echo "$dir: $(echo $units | wc -w) units, systemd-analyze exit code $rc, \
$(wc -l < "$dir.verify") lines of complaint"
  cat "$dir.verify"
  [ "$rc" = 0 ] && [ ! -s "$dir.verify" ]
}

for launch in sim_team real_robot; do
  "$generator" "$launch" --out "$out/$launch" --bin-dir "$bin_dir" --env-dir "$out/$launch" \
      > /dev/null || { echo "FAIL: generating $launch"; fail=1; continue; }
  verify "$out/$launch" || { echo "FAIL: $launch units do not verify"; fail=1; }
done

# Teeth: an unknown restart value and a missing executable must be reported.
cp -r "$out/sim_team" "$out/broken"
sed -i 's/^Restart=always/Restart=sometimes/' "$out/broken/fieldline-camera@.service"
sed -i 's|/fieldline-fusion |/fieldline-no-such-program |' "$out/broken/fieldline-fusion@.service"
if verify "$out/broken" > /dev/null; then
  echo "FAIL: a broken unit verified clean"
  fail=1
fi
[ "$fail" = 0 ] && echo "PASS"
exit "$fail"
