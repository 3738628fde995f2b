// fieldline-colour-calibrate: learns the colour table from frames at a known pose on a known
// field (docs/calibration.md). The field model, projected through the mirror from the pose, says
// which pixels are carpet and which are line; green and white are fitted from those, the ball's
// and obstacles' classes from masks painted over a frame, the others kept from the camera's table.
// Writes boxes or a full lookup table.
//
//   fieldline-colour-calibrate --in frame.png --pose -5.2,1.3,0.4 --out colours.yaml
//   fieldline-colour-calibrate --in frame.png --pose ... --masks painted.png --lut --out c.yaml
//   fieldline-colour-calibrate --render --pose 0.5,0.8,0.3 --realism washed --out c.yaml
//   fieldline-colour-calibrate --evaluate [--drive 500 [--adapt]]   # the measurement in the docs
#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "common/config/config.hpp"
#include "tools/colour_calibrate/calibrate_app.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "Colour calibration from frames at a known pose on a known field: fits green and white "
      "from the pixels the field model predicts, writes the colour YAML and prints the coverage"};
  fieldline::calibration::AppOptions options;
  options.addTo(app);
  CLI11_PARSE(app, argc, argv);
  try {
    return fieldline::calibration::runApp(options);
  } catch (const fieldline::config::Error& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "fieldline-colour-calibrate: {}\n", e.what());
    return 1;
  }
}
