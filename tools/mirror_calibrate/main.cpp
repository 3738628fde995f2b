// fieldline-mirror-calibrate: the mirror centre, the axis offset and the distance table per
// sector, from an image of rings at known distances around the robot or from frames of the field
// at unknown poses (docs/mirror_calibration.md). Writes the camera preset only when it passes its
// checks (read back through the camera service's loader).
//
//   fieldline-mirror-calibrate --rings carpet.png --distances CarpetCalibrator.conf
//       --camera my_robot --out config/camera/my_robot.yaml --debug-png rings.png
//   fieldline-mirror-calibrate --field msl --spot a.png,b.png,c.png,d.png --out venue/cam.yaml
//   fieldline-mirror-calibrate --venue tests/data/venue_cases/tilted_mirror.yaml
//
// Exit codes: 0 written (or nothing asked to be written), 1 refused (nothing written: the
// reason is printed), 2 bad arguments, files or config.
#include <cstdio>
#include <exception>

#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/mirror_calibrate/app.hpp"

namespace cli = fieldline::cli;

int main(int argc, char** argv) {
  cli::App app{
      "Calibrate the omni-directional mirror from an image of rings at known distances, or "
      "from frames of the field (poses searched, or given)"};
  fieldline::calibration::MirrorCalibrateOptions options;
  options.addTo(app);
  FIELDLINE_CLI_PARSE(app, argc, argv);
  try {
    return fieldline::calibration::runMirrorCalibrate(options);
  } catch (const fieldline::calibration::Refusal& e) {
    std::fprintf(stderr, "fieldline-mirror-calibrate: refused, nothing written: %s\n", e.what());
    return fieldline::calibration::kRefusedExit;
  } catch (const fieldline::config::Error& e) {
    std::fprintf(stderr, "config error: %s\n", e.what());
    return fieldline::calibration::kBadInputExit;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fieldline-mirror-calibrate: %s\n", e.what());
    return fieldline::calibration::kBadInputExit;
  }
}
