// fieldline-colour-calibrate: learns the colour table from frames (docs/calibration.md). Without a
// pose, from the frames alone: the floor is the dominant colour around the robot, lines the narrow
// bright ridges on it, ball and robots what is neither (found once the line points are fitted to
// the field). With known poses, the field model projected through the mirror says which pixels
// are carpet and which line. Either way the tool ends with its check (the tracker's line points
// with the new table, fitted to the field) and writes only a table that passes it.
// Exit codes: 0 written, 1 refused (nothing written), 2 bad arguments or config.
//
//   fieldline-colour-calibrate --camera venue/cam.yaml --in f1.png --in f2.png --out colours.yaml
//   fieldline-colour-calibrate --in frame.png --pose -5.2,1.3,0.4 --out colours.yaml
//   fieldline-colour-calibrate --in frame.png --pose ... --masks painted.png --lut --out c.yaml
//   fieldline-colour-calibrate --render --pose 0.5,0.8,0.3 --realism washed --out c.yaml
//   fieldline-colour-calibrate --evaluate [--drive 500 [--adapt]]   # the measurement in the docs
#include <fmt/core.h>

#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/colour_calibrate/calibrate_app.hpp"

namespace cli = fieldline::cli;

int main(int argc, char** argv) {
  cli::App app{
      "Colour calibration from frames: floor, lines, ball and robots from the frames alone (or "
      "from the field model at known poses); checks the table on the frames before writing it"};
  fieldline::calibration::AppOptions options;
  options.addTo(app);
  FIELDLINE_CLI_PARSE(app, argc, argv);
  try {
    return fieldline::calibration::runApp(options);
  } catch (const fieldline::calibration::Refusal& e) {
    fmt::print(stderr, "fieldline-colour-calibrate: refused, nothing written: {}\n", e.what());
    return fieldline::calibration::kRefusedExit;
  } catch (const fieldline::config::Error& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return fieldline::calibration::kBadInputExit;
  } catch (const std::exception& e) {
    fmt::print(stderr, "fieldline-colour-calibrate: {}\n", e.what());
    return fieldline::calibration::kBadInputExit;
  }
}
