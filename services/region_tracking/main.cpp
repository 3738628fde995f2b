// fieldline-region-tracking: the vision process. Tracks the colour regions of every
// CAMERA_IMAGE (seed chapter 3) and publishes VISION_BALL and VISION_OBSTACLES for every frame
// and VISION_LINES every n-th frame, each with the frame's exposure time.
#include <spdlog/spdlog.h>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/camera/colour.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "services/region_tracking/tracking_node.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Region tracking: grow/shrink tracking of the colour regions in each CAMERA_IMAGE, field "
      "lines along the green boundaries (VISION_LINES), the ball (VISION_BALL) and obstacles "
      "(VISION_OBSTACLES). SIGUSR1 resets the colour adaptation to the calibrated table."};
  bus::CommonOptions common;
  common.addTo(app);
  std::string camera_preset = "omni_sim";
  std::string vision_config;
  std::string field = "msl";
  int lines_every = 3;
  app.add_option("--camera", camera_preset, "Camera preset (mirror model and colour table)")
      ->capture_default_str();
  app.add_option("--vision-config", vision_config,
                 "YAML with tracker, blocks, lines, ball and obstacles sections and optionally "
                 "health and adaptation (default: "
                 "built-in values, see docs/region_tracking.md)");
  app.add_option("--field", field,
                 "Field preset or YAML (with fusion's ROBOT_STATE: do the line points fit the "
                 "field, can a ball be there); 'none': no field checks")
      ->capture_default_str();
  app.add_option("--lines-every", lines_every, "Extract field lines on every n-th frame")
      ->check(cli::Range(1, 1000))
      ->capture_default_str();
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("region_tracking", [&] {
    common.resolve("region_tracking");
    region_tracking::TrackingNodeOptions options;
    const camera::CameraModel camera = camera::loadCameraPreset(camera_preset);
    options.mirror = camera.mirror;
    options.colours = camera::loadColourTablePreset(camera.colour_table);
    if (!vision_config.empty()) {
      const config::Node root = config::Node::loadFile(vision_config);
      options.vision = region_tracking::loadVisionParams(root);
      // Optional: when the vision counts as blind (docs/calibration.md, vision health).
      if (const std::optional<config::Node> health = root.childIf("health")) {
        options.health = region_tracking::loadVisionHealthParams(*health);
      }
      // Optional: green and white follow the light (docs/calibration.md, staying calibrated).
      if (const std::optional<config::Node> adaptation = root.childIf("adaptation")) {
        options.adaptation = region_tracking::loadColourAdaptationParams(*adaptation);
      }
    }
    options.lines_every_frames = lines_every;
    if (field != "none") {
      options.field = std::make_shared<const field::FieldModel>(field::loadFieldPreset(field));
    }

    const RobotClock clock = bus::robotClockFromEnvironment();
    if (common.print_io) return bus::printIo(region_tracking::trackingIo());
    if (common.check_args) return 0;
    bus::installStopSignals();
    bus::Node node({.process = "region_tracking", .robot_id = common.robot, .url = common.bus_url},
                   clock);
    region_tracking::TrackingNode tracking(node, std::move(options));
    // `kill -USR1 <pid>`: the colour adaptation back to the calibrated table (docs/calibration.md).
    region_tracking::installColourResetSignal(tracking);
    spdlog::info("tracking CAMERA_IMAGE with camera preset {}, lines every {} frames",
                 camera_preset, lines_every);
    return node.run();
  });
}
