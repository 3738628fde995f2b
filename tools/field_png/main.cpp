// fieldline-field-png: draws a field preset (green carpet up to the barrier, white lines at their
// true width, goals in their colour, penalty marks) to a PNG, field +x to the right, +y up; or,
// with --all DIR, every preset of config/field to DIR/field_NAME.png.
//
//   fieldline-field-png --field msl --out docs/images/field_msl.png --px-per-m 30
//   fieldline-field-png --all docs/images --px-per-m 30
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "tools/field_png/field_drawing.hpp"

namespace cli = fieldline::cli;

namespace {

// Draws one preset; false (with the reason on stderr) when it does not load or cannot be written.
bool drawOne(const std::string& field, const std::string& out, double px_per_m) {
  try {
    const fieldline::field::FieldModel model = fieldline::field::loadFieldPreset(field);
    const cv::Mat image = fieldline::field_png::drawField(model, px_per_m);
    if (!cv::imwrite(out, image, {cv::IMWRITE_PNG_COMPRESSION, 9})) {
      std::cerr << "cannot write " << out << "\n";
      return false;
    }
    std::cout << "wrote " << out << " (" << image.cols << " x " << image.rows << " px, field '"
              << model.name() << "', " << model.segments().size() << " segments, "
              << model.arcs().size() << " arcs)\n";
    return true;
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return false;
  }
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Draws a field preset to a PNG: green carpet up to the barrier, white lines at their true "
      "width, goals in their colour. Field +x points right, +y up."};
  std::string field = "msl";
  std::string out;
  std::string all;
  double px_per_m = 40.0;
  app.add_option("--field", field, "Preset name (config/field/NAME.yaml) or path to a YAML file")
      ->capture_default_str();
  auto* out_option = app.add_option("--out", out, "Output PNG file");
  app.add_option("--all", all, "Draw every preset of config/field to DIR/field_NAME.png")
      ->excludes(out_option);
  app.add_option("--px-per-m", px_per_m, "Pixels per metre")
      ->check(cli::Range(5.0, 500.0))
      ->capture_default_str();
  FIELDLINE_CLI_PARSE(app, argc, argv);
  if (out.empty() && all.empty()) {
    std::cerr << "fieldline-field-png: give --out FILE or --all DIR\n";
    return 2;
  }
  if (all.empty()) return drawOne(field, out, px_per_m) ? 0 : 1;

  namespace fs = std::filesystem;
  std::error_code error;
  fs::create_directories(all, error);
  if (error) {
    std::cerr << "fieldline-field-png: cannot create " << all << ": " << error.message() << "\n";
    return 1;
  }
  std::vector<std::string> names;
  for (const auto& entry :
       fs::directory_iterator(fieldline::config::projectRoot() + "/config/field")) {
    if (entry.path().extension() == ".yaml") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  if (names.empty()) {
    std::cerr << "fieldline-field-png: no presets in config/field\n";
    return 1;
  }
  int failed = 0;
  for (const std::string& name : names) {
    if (!drawOne(name, (fs::path(all) / ("field_" + name + ".png")).string(), px_per_m)) ++failed;
  }
  return failed == 0 ? 0 : 1;
}
