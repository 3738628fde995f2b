// fieldline-feature-recognition: layer 3 of the localization (seed 4.13). Recognises the centre
// circle, the penalty-area corners, L-corners, T-junctions and straight lines in every
// VISION_LINES message and publishes them with the field poses they imply as FIELD_FEATURES,
// stamped with the same exposure time.
#include <iostream>

#include <spdlog/spdlog.h>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/cli/cli.hpp"
#include "common/field/field_model.hpp"
#include "services/feature_recognition/feature_node.hpp"
#include "services/feature_recognition/settings.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Feature recognition: centre circle and penalty-area corners (and L-corners, T-junctions, "
      "straight lines) in each VISION_LINES message, published with every field pose they "
      "imply as FIELD_FEATURES."};
  bus::CommonOptions common;
  common.addTo(app);
  std::string field_name = "msl";
  app.add_option("--field", field_name, "Field preset (msl, fu2004) or YAML file")
      ->capture_default_str();
  std::string config_name = "default";
  app.add_option("--config", config_name,
                 "Settings: preset name (config/feature_recognition/NAME.yaml), YAML path or none "
                 "(the code's defaults)")
      ->capture_default_str();
  bool print_config = false;
  bool print_settings_table = false;
  app.add_flag("--print-config", print_config, "Print the settings in effect as YAML and exit");
  app.add_flag("--print-settings-table", print_settings_table,
               "Print every setting's key, default, unit, range and why as Markdown and exit");
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    // --help exits 0; bad arguments exit 2.
    return app.exit(e) == 0 ? 0 : 2;
  }

  return bus::runMain("feature_recognition", [&] {
    common.resolve("feature_recognition");
    const field::FieldModel field = field::loadFieldPreset(field_name);
    const feature_recognition::RecognitionParams params =
        feature_recognition::loadRecognitionPreset(config_name);
    if (print_settings_table) {
      std::cout << feature_recognition::recognitionSettingsMarkdown();
      return 0;
    }
    if (print_config) {
      std::cout << feature_recognition::recognitionConfigYaml(params);
      return 0;
    }
    const RobotClock clock = bus::robotClockFromEnvironment();
    if (common.print_io) return bus::printIo(feature_recognition::featureIo());
    if (common.check_args) return 0;
    bus::installStopSignals();
    bus::Node node(
        {.process = "feature_recognition", .robot_id = common.robot, .url = common.bus_url}, clock);
    feature_recognition::FeatureNode features(node, field, params);
    spdlog::info("recognising features on field {}", field.name());
    return node.run();
  });
}
