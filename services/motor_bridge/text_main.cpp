// fieldline-text-bridge: the example adapter for a motor controller with its own plain-text
// protocol (docs/own-controller.md): MOTION_COMMAND -> "V vx vy omega" lines on the serial line;
// the controller's "O t_us ticks..." or "S t_us vx vy omega" lines -> ODOMETRY.
#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/robot/robot_params.hpp"
#include "services/motor_bridge/text_bridge_node.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Text bridge (an example adapter for a team's own motor controller, "
      "docs/own-controller.md): sends MOTION_COMMAND as 'V vx vy omega' lines (m/s, m/s, rad/s) "
      "on a serial line and publishes the controller's 'O t_us ticks...' lines (wheel ticks, as "
      "many as the robot file has wheels) or 'S t_us vx vy omega' lines (body velocity) as "
      "ODOMETRY stamped at the sampling time. Reconnects when the device disappears; sends zero "
      "velocity when commands stop or expire."};
  bus::CommonOptions common;
  common.addTo(app);
  std::string robot_config = "fu2004";
  std::string bridge_config = "motor_bridge";
  std::string device;
  app.add_option("--robot-config", robot_config, "Robot preset name or YAML path")
      ->capture_default_str();
  app.add_option("--bridge-config", bridge_config,
                 "Serial line config (config/robot/<name>.yaml or a path)")
      ->capture_default_str();
  app.add_option("--device", device, "Serial device; overrides the config");
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("text_bridge", [&] {
    common.resolve("text_bridge");
    const auto params = robot::loadRobotPreset(robot_config);
    auto config = motor_bridge::loadBridgeConfig(
        config::Node::loadFile(config::resolvePreset("robot", bridge_config)));
    if (!device.empty()) config.device = device;
    config.device = motor_bridge::deviceForRobot(config.device, common.robot);

    const RobotClock clock = bus::robotClockFromEnvironment();
    if (common.print_io) return bus::printIo(motor_bridge::textBridgeIo(config.device));
    if (common.check_args) return 0;
    bus::installStopSignals();
    bus::Node node({.process = "text_bridge", .robot_id = common.robot, .url = common.bus_url},
                   clock);
    motor_bridge::TextBridgeNode bridge(node, params, config);
    bridge.start();
    const int rc = node.run();
    bridge.stop();
    return rc;
  });
}
