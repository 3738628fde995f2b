// fieldline-motor-bridge: MOTION_COMMAND from the robot's bus -> velocity frames on the serial
// line; odometry frames from the controller -> ODOMETRY at 50 Hz. See docs/serial-protocol.md.
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <boost/asio/io_context.hpp>
#include <cmath>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/config/config.hpp"
#include "common/robot/robot_params.hpp"
#include "services/motor_bridge/bridge.hpp"
#include "services/motor_bridge/serial_link.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  CLI::App app{
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
  CLI11_PARSE(app, argc, argv);

  return bus::runMain("motor_bridge", [&] {
    common.resolve("motor_bridge");
    const auto params = robot::loadRobotPreset(robot_config);
    auto link_config = motor_bridge::loadBridgeConfig(
        config::Node::loadFile(config::resolvePreset("robot", bridge_config)));
    if (!device.empty()) link_config.device = device;
    link_config.device = motor_bridge::deviceForRobot(link_config.device, common.robot);

    SystemClock clock;
    bus::installStopSignals();
    bus::Node node({.process = "motor_bridge", .robot_id = common.robot, .url = common.bus_url},
                   clock);
    motor_bridge::BridgeCore core(params);
    boost::asio::io_context io;
    std::vector<motor_bridge::OdometryOutput> outputs;
    std::uint64_t published_errors = 0;

    motor_bridge::SerialLink* link_ptr = nullptr;
    motor_bridge::SerialLink link(
        io, {link_config.device, link_config.baud_rate, link_config.reconnect_interval},
        [&](std::span<const std::uint8_t> bytes) {
          outputs.clear();
          core.onBytes(bytes, clock.now(), outputs);
          for (const auto& o : outputs) {
            odometry_t msg{};
            msg.header.utime = o.utime;
            for (int i = 0; i < 3; ++i)
              msg.ticks[i] = o.ticks[i];
            msg.controller_utime = o.controller_utime;
            msg.dx = o.movement.dx;
            msg.dy = o.movement.dy;
            msg.dphi = o.movement.dphi;
            msg.vx = o.vx;
            msg.vy = o.vy;
            msg.omega = o.omega;
            msg.status = o.status;
            node.publish(bus::channels::kOdometry, msg);
            // The robot's speed as its wheels tell it: the status table's headline for this robot.
            node.setMetric("speed_mps", std::hypot(o.vx, o.vy));
          }
        },
        [&](bool connected) {
          if (connected) {
            spdlog::info("serial line {} open", link_config.device);
            core.onConnected();
            link_ptr->send(core.helloFrame());
          } else {
            node.reportError("serial_disconnect", link_ptr->lastError());
          }
        });
    link_ptr = &link;

    node.subscribe(bus::channels::kMotionCommand, [&](const motion_command_t& m) {
      if (!core.onCommand({m.vx, m.vy, m.omega, m.deadline_utime}, node.now())) {
        node.reportError("command_rejected", "command not used (NaN or expired)");
      }
    });
    const auto period = static_cast<Utime>(1e6 / link_config.command_rate);
    node.every(period, [&] { link.send(core.commandFrame(node.now())); });
    node.every(kMicrosPerSecond, [&] {
      // Malformed frames and rejections from the core go into SERVICE_STATUS.
      std::uint64_t total = 0;
      for (const auto& [kind, n] : core.counters()) {
        node.setMetric(kind + "_total", static_cast<double>(n));
        if (kind.starts_with("serial_")) total += n;
      }
      if (total > published_errors) {
        node.reportError("serial_bad_frames",
                         std::to_string(total - published_errors) + " malformed frames dropped");
        published_errors = total;
      }
      node.setMetric("serial_connected", link.connected() ? 1.0 : 0.0);
      // Without its serial line the bridge cannot do its job: the status says error.
      node.status().setFault(!link.connected());
      node.setMetric("serial_reconnects", static_cast<double>(link.stats().opens));
      node.setMetric("serial_frames_dropped", static_cast<double>(link.stats().frames_dropped));
      node.setMetric("odometry_samples_lost", static_cast<double>(core.samplesLost()));
      node.setMetric("command_active", core.commandActive(node.now()) ? 1.0 : 0.0);
    });

    link.start();
    if (!link.connected()) spdlog::warn("{}; retrying", link.lastError());
    while (!node.stopRequested()) {
      node.spinOnce(1);
      io.poll();
      if (io.stopped()) io.restart();
    }
    // Leave the robot standing, not driving until its watchdog fires.
    link.send(core.stopFrame());
    io.poll();
    link.stop();
    return 0;
  });
}
