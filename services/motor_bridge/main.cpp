// fieldline-motor-bridge: MOTION_COMMAND from the robot's bus -> velocity frames on the serial
// line; odometry frames from the controller -> ODOMETRY at 50 Hz. See docs/serial-protocol.md.
#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/device/device_check.hpp"
#include "common/robot/robot_params.hpp"
#include "services/motor_bridge/bridge_node.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Motor bridge: turns MOTION_COMMAND into velocity frames for the motor controller on a "
      "serial line (a real /dev/ttyUSB0 or world_sim's pseudo-terminal) and the controller's "
      "wheel ticks into ODOMETRY. Reconnects when the device disappears and returns; commands "
      "zero velocity when commands stop or expire."};
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
  app.add_option("--device", device,
                 "Serial device; overrides the config (default /tmp/fieldline/robot<N>.tty)");
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("motor_bridge", [&] {
    common.resolve("motor_bridge");
    const auto params = robot::loadRobotPreset(robot_config);
    auto config = motor_bridge::loadBridgeConfig(
        config::Node::loadFile(config::resolvePreset("robot", bridge_config)));
    if (!device.empty()) config.device = device;
    config.device = motor_bridge::deviceForRobot(config.device, common.robot);

    const RobotClock clock = bus::robotClockFromEnvironment();
    if (common.print_io) return bus::printIo(motor_bridge::bridgeIo(config.device));
    // The serial device is there and usable (not opened: that resets many controllers).
    if (common.check_args) {
      return device::reportProblems("motor_bridge", {device::checkSerial(config.device)});
    }
    bus::installStopSignals();
    bus::Node node({.process = "motor_bridge", .robot_id = common.robot, .url = common.bus_url},
                   clock);
    motor_bridge::BridgeNode bridge(node, params, config);
    bridge.start();
    const int rc = node.run();
    bridge.stop();
    return rc;
  });
}
