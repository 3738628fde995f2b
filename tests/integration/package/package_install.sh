#!/usr/bin/env bash
# The .deb installs and runs without the source tree (issue 29 item 5):
#  1. cpack builds the .deb from this build (the robot component; the same as scripts/package);
#  2. its control file depends on the Debian runtime libraries dpkg-shlibdeps found;
#  3. its content (dpkg-deb -x into a scratch root under /tmp) has the robot's programs, data,
#     systemd units and sysctl settings, and none of the dev component (attack, bench, test nodes);
#  4. no installed file names the source or build tree (the strings of every binary included);
#  5. in a private mount namespace where the source and build trees are hidden (an empty tmpfs
#     over each), from another folder, with FIELDLINE_ROOT unset and PATH without the build:
#     the installed fieldline-launch --dry-run on the installed real_robot.yaml exits 0 with the
#     devices given as existing stand-ins, every command line runs an installed program, and the
#     installed viewer finds its page and presets (--check-args).
# Usage: package_install.sh BUILD_DIR SOURCE_ROOT
set -uo pipefail
build=$(realpath "$1")
src=$(realpath "$2")
for tool in cpack dpkg-deb; do
  command -v $tool > /dev/null || { echo "SKIP: $tool is not installed (scripts/setup)"; exit 77; }
done
work=$(mktemp -d /tmp/fieldline-package-test.XXXXXX)
pty_pid=""
cleanup() {
  [ -n "$pty_pid" ] && kill "$pty_pid" 2> /dev/null
  rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  exit 1
}

# 1. The package.
start=$(date +%s.%N)
if ! (cd "$build" && cpack -G DEB -B "$work/pkg" > "$work/cpack.log" 2>&1); then
  cat "$work/cpack.log"
  fail "cpack failed"
fi
deb=$(ls "$work"/pkg/fieldline_*.deb 2> /dev/null | head -n 1)
[ -f "$deb" ] || { cat "$work/cpack.log"; fail "cpack wrote no fieldline_*.deb"; }
echo "package: $(basename "$deb"), $(du -k "$deb" | cut -f1) KiB, built in \
$(awk "BEGIN { printf \"%.1f\", $(date +%s.%N) - $start }") s"

# 2. Dependencies, from dpkg-shlibdeps.
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
for lib in libc6 libstdc++6 liblcm1 libopencv-core libopencv-imgproc libopencv-videoio libyaml-cpp \
    libsodium libspdlog libfmt libsystemd0; do
  echo "$depends" | grep -q "\b$lib" || fail "Depends lacks $lib"
done

# 3. Content.
root="$work/root"
dpkg-deb -x "$deb" "$root" || fail "dpkg-deb -x"
for f in usr/bin/fieldline-launch usr/bin/fieldline-camera usr/bin/fieldline-region-tracking \
    usr/bin/fieldline-feature-recognition usr/bin/fieldline-fusion usr/bin/fieldline-motor-bridge \
    usr/bin/fieldline-pilot usr/bin/fieldline-teamcomm usr/bin/fieldline-team-key \
    usr/bin/fieldline-viewer usr/bin/fieldline-systemd-units usr/bin/fieldline-colour-calibrate \
    usr/bin/fieldline-mirror-calibrate usr/bin/fieldline-bus-check usr/bin/fieldline-replay \
    usr/share/fieldline/config/launch/real_robot.yaml usr/share/fieldline/web/index.html \
    usr/lib/systemd/system/fieldline-robot@.target usr/lib/systemd/system/fieldline-camera@.service \
    usr/share/fieldline/systemd/robot1.env usr/share/fieldline/systemd/robot6.env \
    usr/lib/sysctl.d/60-fieldline.conf usr/share/doc/fieldline/robot-install.md; do
  [ -e "$root/$f" ] || fail "the package has no /$f"
done
for f in fieldline-team-attack fieldline-team-probe fieldline-bench-tracking \
    fieldline-launch-test-node fieldline-ready-probe; do
  [ -e "$root/usr/bin/$f" ] && fail "the package holds the dev tool $f"
done
echo "content: $(find "$root" -type f | wc -l) files, $(ls "$root/usr/bin" | wc -l) programs"

# 4. No path into the source or build tree, in any file (binaries included).
if grep -rlF --binary-files=text -e "$src" -e "$build" "$root" > "$work/paths"; then
  echo "files naming $src or $build:"
  cat "$work/paths"
  fail "installed files point into the source tree"
fi
echo "no installed file names $src or $build"

# 5. Run it with the source and build trees hidden.
# Stand-ins for the robot's devices (docs/launch.md, "Devices"): a pseudo-terminal for the motor
# controller's serial line, a named pipe for the camera.
python3 -c '
import os, pty, sys, time
master, slave = pty.openpty()
print(os.ttyname(slave), flush=True)
time.sleep(300)
' > "$work/pty" &
pty_pid=$!
for _ in $(seq 50); do [ -s "$work/pty" ] && break; sleep 0.1; done
serial=$(head -n 1 "$work/pty")
[ -c "$serial" ] || fail "no pseudo-terminal for the serial stand-in"
camera="$work/video0"
mkfifo "$camera"
mkdir -p "$work/elsewhere"
launch="$root/usr/share/fieldline/config/launch/real_robot.yaml"
# The installed launch file unchanged; the devices from the command line (--set).
run_hidden() {
  local hide="mount -t tmpfs none '$src'"
  case "$build" in "$src"/*) ;; *) hide="$hide && mount -t tmpfs none '$build'" ;; esac
  local cmd="$hide && cd '$work/elsewhere' && [ ! -e '$src/config' ] && $*"
  if unshare -m true 2> /dev/null; then
    unshare -m sh -c "$cmd"
  else
    unshare -rm sh -c "$cmd"
  fi
}
stand_ins=()
if grep -q '^settings:' "$launch"; then
  stand_ins=(--set camera_device="$camera" --set motor_device="$serial")
fi
run_hidden env -u FIELDLINE_ROOT PATH=/usr/bin:/bin "$root/usr/bin/fieldline-launch" "$launch" \
    --dry-run "${stand_ins[@]}" > "$work/dry_run" 2>&1
rc=$?
cat "$work/dry_run"
[ "$rc" = 0 ] || fail "the installed fieldline-launch --dry-run exited $rc"
# Every process of the launch file runs an installed program, none is skipped.
grep -q "NOT BUILT" "$work/dry_run" && fail "a process of the real launch is not installed"
commands=$(grep -v '^#' "$work/dry_run" | grep -c "^$root/usr/bin/fieldline-")
others=$(grep -v '^#' "$work/dry_run" | grep -vc "^$root/usr/bin/fieldline-")
[ "$commands" -gt 0 ] && [ "$others" = 0 ] || fail "command lines not all installed programs"
for process in camera region_tracking motor_bridge pilot; do
  grep -q "^# \[r[0-9]* $process\]" "$work/dry_run" || fail "no $process in the dry run"
done
echo "dry run: $commands processes, every one an installed program"
# Without the stand-ins, on a machine without the robot's devices: exit 2, each device named.
if [ ${#stand_ins[@]} -gt 0 ] && [ ! -e /dev/video0 ] && [ ! -e /dev/ttyUSB0 ]; then
  run_hidden env -u FIELDLINE_ROOT PATH=/usr/bin:/bin "$root/usr/bin/fieldline-launch" "$launch" \
      --dry-run > "$work/no_devices" 2>&1
  rc=$?
  [ "$rc" = 2 ] || { cat "$work/no_devices"; fail "--dry-run without the devices exited $rc, not 2"; }
  for device in /dev/video0 /dev/ttyUSB0; do
    grep -q "error: .*$device: no such device" "$work/no_devices" ||
        { cat "$work/no_devices"; fail "--dry-run without the devices does not name $device"; }
  done
  echo "without the devices: exit 2, /dev/video0 and /dev/ttyUSB0 named"
fi
run_hidden env -u FIELDLINE_ROOT PATH=/usr/bin:/bin "$root/usr/bin/fieldline-viewer" \
    --check-args --no-sim > "$work/viewer" 2>&1 || { cat "$work/viewer"; fail "installed viewer"; }
echo "PASS"
