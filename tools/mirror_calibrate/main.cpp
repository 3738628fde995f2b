// fieldline-mirror-calibrate: the mirror centre, the axis offset and the distance table per
// sector from an image of rings at known distances around the robot (docs/mirror_calibration.md).
//
//   fieldline-mirror-calibrate --rings carpet.png --distances CarpetCalibrator.conf
//       --camera my_robot --out config/camera/my_robot.yaml --debug-png rings.png
//   fieldline-mirror-calibrate --render-rings --render-offset 0.06,-0.04 --realism all
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "common/config/config.hpp"
#include "tools/mirror_calibrate/app.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Calibrate the omni-directional mirror from an image of rings at known distances"};
  fieldline::calibration::MirrorCalibrateOptions options;
  options.addTo(app);
  CLI11_PARSE(app, argc, argv);
  try {
    return fieldline::calibration::runMirrorCalibrate(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fieldline-mirror-calibrate: %s\n", e.what());
    return 1;
  }
}
