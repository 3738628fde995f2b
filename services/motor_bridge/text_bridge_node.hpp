// The fieldline-text-bridge process's bus side (the example adapter for a controller with its own
// text protocol, docs/own-controller.md): MOTION_COMMAND in, V lines out on the serial line at the
// command rate; O or S lines in, ODOMETRY out, stamped with the sampling time. The same event
// loop as the binary bridge (BridgeNode): the node waits on the line's descriptor next to LCM's.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <fieldline/motion_command_t.hpp>
#include <fieldline/odometry_t.hpp>

#include "common/bus/node.hpp"
#include "common/robot/robot_params.hpp"
#include "services/motor_bridge/bridge.hpp"
#include "services/motor_bridge/command_source.hpp"
#include "services/motor_bridge/serial_link.hpp"
#include "services/motor_bridge/text_bridge.hpp"

namespace fieldline::motor_bridge {

// What the text bridge reads and writes with the controller on `device`
// (fieldline-text-bridge --print-io).
bus::ProcessIo textBridgeIo(const std::string& device);

class TextBridgeNode {
 public:
  // Subscribes MOTION_COMMAND and sets the timers on `node`; opens the line with start().
  TextBridgeNode(bus::Node& node, const robot::RobotParams& params, BridgeConfig config);
  ~TextBridgeNode();
  TextBridgeNode(const TextBridgeNode&) = delete;
  TextBridgeNode& operator=(const TextBridgeNode&) = delete;

  void start();
  // Sends a zero command and closes the line.
  void stop();

  const SerialLink& link() const { return link_; }
  const TextBridgeCore& core() const { return core_; }

 private:
  void onBytes(std::span<const std::uint8_t> bytes);
  void onLinkState(bool connected);
  void sendCommand();
  void publishMetrics();
  void send(const std::string& line);

  bus::Node& node_;
  BridgeConfig config_;
  TextBridgeCore core_;
  // Which MOTION_COMMANDs may drive the robot (its own robot id, one publisher).
  CommandSource source_;
  SerialLink link_;
  std::optional<bus::Node::WatchId> line_watch_;
  std::vector<perception::OdometryReading> outputs_;
  odometry_t odometry_{};
  std::uint64_t reported_rejects_ = 0;
  bool stopped_ = false;
};

}  // namespace fieldline::motor_bridge
