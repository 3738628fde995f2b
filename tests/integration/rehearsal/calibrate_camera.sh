#!/usr/bin/env bash
# Writes the real launch's camera preset, config/camera/robot_640.yaml (image, mirror table,
# pipeline) and its colour classes config/camera/robot_640_colours.yaml, with the calibration tools
# (docs/mirror_calibration.md, docs/calibration.md) and frames of the simulator's 640x480 camera
# (omni_sim_640), the camera the rehearsal (real_robot_rehearsal) feeds the launch with:
#   - the mirror from a ring carpet the mirror tool renders through omni_sim_640's mirror, with
#     no realism knobs (--render-rings; residuals 0.06 %). Field frames at an unknown pose work at
#     640x480 too (--spot, docs/calibration.md section 0; the venue case sim_640: 0.53 % from 1
#     to 5 m), but the clean rings are more exact;
#   - the colour classes from four frames of the field at known poses, rendered by the simulator's
#     camera (fieldline-camera-snapshot --render), through the mirror just calibrated
#     (--camera robot_640.yaml), the ball and robot classes kept from colours_sim.
# On a real robot the same tools run on frames of its own camera: rings laid around the robot
# (--rings FRAME --distances ...) and frames at known poses (README.md, "On a real robot").
#
#   tests/integration/rehearsal/calibrate_camera.sh build/bin [OUT_DIR [FRAMES_DIR]]
#
# OUT_DIR defaults to config/camera; FRAMES_DIR (default: a temporary folder) keeps the frames.
set -eu
bin=$(realpath "${1:?usage: calibrate_camera.sh BUILD/bin [OUT_DIR [FRAMES_DIR]]}")
root=$(cd "$(dirname "$0")/../../.." && pwd)
out=$(realpath -m "${2:-$root/config/camera}")
frames=${3:-}
if [ -z "$frames" ]; then frames=$(mktemp -d); trap 'rm -rf "$frames"' EXIT; fi
mkdir -p "$out" "$frames"
frames=$(realpath "$frames")
export FIELDLINE_ROOT="$root"
# Poses x,y,phi (m, rad): the penalty area, the centre circle, a side line, the other half.
poses=(-6.0,1.5,0.4 0.5,0.8,0.3 -3.5,-2.5,2.0 4.0,3.0,-1.0)
colour_args=()
for i in "${!poses[@]}"; do
  frame="$frames/frame$i.png"
  "$bin/fieldline-camera-snapshot" --render "${poses[$i]}" --config omni_sim_640 --field msl \
    --out "$frame" > /dev/null
  colour_args+=(--in "$frame" --pose "${poses[$i]}")
done
echo "== mirror: fieldline-mirror-calibrate --render-rings --camera omni_sim_640"
"$bin/fieldline-mirror-calibrate" --render-rings --camera omni_sim_640 \
  --debug-png "$frames/rings.png" --out "$out/robot_640.yaml"
# The colour tool maps pixels to the floor with the camera preset's mirror: the one just written.
echo "== colours: fieldline-colour-calibrate ${colour_args[*]} --camera robot_640.yaml --base colours_sim"
# (From OUT_DIR: the table's header names the preset without this machine's folders.)
(cd "$out" && "$bin/fieldline-colour-calibrate" "${colour_args[@]}" --field msl \
  --camera robot_640.yaml --base colours_sim --out robot_640_colours.yaml)
# The camera preset names its own colour classes.
sed -i 's/^colour_table: .*/colour_table: robot_640_colours/' "$out/robot_640.yaml"
sed -i "1i # Made by tests/integration/rehearsal/calibrate_camera.sh: the calibration tools on frames of the simulator's omni_sim_640 camera." \
  "$out/robot_640.yaml" "$out/robot_640_colours.yaml"
echo "wrote $out/robot_640.yaml and $out/robot_640_colours.yaml"
