#include "services/motor_bridge/text_bridge_node.hpp"

#include <cmath>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "common/msg/motion_command.hpp"
#include "common/msg/odometry.hpp"

namespace fieldline::motor_bridge {

TextBridgeNode::TextBridgeNode(bus::Node& node, const robot::RobotParams& params,
                               BridgeConfig config)
    : node_(node),
      config_(std::move(config)),
      core_(params),
      source_(node.robotId()),
      link_(
          {config_.device, config_.baud_rate, config_.reconnect_interval},
          [this](std::span<const std::uint8_t> bytes) { onBytes(bytes); },
          [this](bool connected) { onLinkState(connected); }) {
  if (!(config_.command_rate > 0.0)) throw std::invalid_argument("command_rate must be positive");
  node_.subscribe(bus::channels::kMotionCommand, [this](const motion_command_t& m) {
    // Only this robot's commands, from one publisher (command_source.hpp).
    const auto source = source_.onCommand(m.header.robot_id, m.header.publisher_id, node_.now());
    if (source.verdict != CommandSource::Verdict::kAccept) {
      node_.reportError(source.verdict == CommandSource::Verdict::kOtherRobot
                            ? "command_other_robot"
                            : "command_second_publisher",
                        source.reason);
      return;
    }
    const auto command = msg::fromMessage(m);
    if (!core_.onCommand({command.vx, command.vy, command.omega, command.deadline_utime},
                         node_.now())) {
      node_.reportError("command_rejected", "command not used (NaN or expired)");
    }
  });
  node_.every(static_cast<Utime>(1e6 / config_.command_rate), [this] { sendCommand(); });
  node_.every(kMicrosPerSecond, [this] { publishMetrics(); });
  // An open line is not enough: the controller's samples must flow.
  node_.requireOutput(
      bus::channels::kOdometry,
      bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kOdometry.name));
  node_.declareIo(textBridgeIo(config_.device));
}

bus::ProcessIo textBridgeIo(const std::string& device) {
  return bus::ProcessIo("text_bridge")
      .readsIfPresent(bus::channels::kMotionCommand)
      .writes(bus::channels::kOdometry)
      .link("serial", device, bus::Link::Direction::kBoth);
}

TextBridgeNode::~TextBridgeNode() {
  stop();
}

void TextBridgeNode::start() {
  stopped_ = false;
  link_.start();
  if (!link_.connected()) spdlog::warn("{}; retrying", link_.lastError());
}

void TextBridgeNode::stop() {
  if (stopped_) return;
  stopped_ = true;
  send(core_.stopLine());
  if (line_watch_) node_.unwatchFd(*line_watch_);
  line_watch_.reset();
  link_.stop();
}

void TextBridgeNode::send(const std::string& line) {
  link_.send(std::span(reinterpret_cast<const std::uint8_t*>(line.data()), line.size()));
}

void TextBridgeNode::onBytes(std::span<const std::uint8_t> bytes) {
  outputs_.clear();
  core_.onBytes(bytes, node_.now(), outputs_);
  for (const auto& o : outputs_) {
    msg::toMessage(o, odometry_);
    node_.publish(bus::channels::kOdometry, odometry_);
    node_.setMetric("speed_mps", std::hypot(o.vx, o.vy));
  }
}

void TextBridgeNode::onLinkState(bool connected) {
  if (line_watch_) node_.unwatchFd(*line_watch_);
  line_watch_.reset();
  if (!connected) {
    node_.reportError("serial_disconnect", link_.lastError());
    return;
  }
  spdlog::info("serial line {} open", config_.device);
  line_watch_ = node_.watchFd(link_.nativeHandle(), [this] { link_.onReadable(); });
  core_.onConnected();
}

void TextBridgeNode::sendCommand() {
  send(core_.commandLine(node_.now()));
  link_.poll();
}

void TextBridgeNode::publishMetrics() {
  std::uint64_t rejects = 0;
  for (const auto& [kind, n] : core_.counters()) {
    node_.setMetric(kind + "_total", static_cast<double>(n));
    if (kind.starts_with("text_")) rejects += n;
  }
  if (rejects > reported_rejects_) {
    node_.reportError("text_bad_lines", std::to_string(rejects - reported_rejects_) +
                                            " lines dropped, last: " + core_.lastError());
    reported_rejects_ = rejects;
  }
  node_.setMetric("serial_connected", link_.connected() ? 1.0 : 0.0);
  node_.status().setFault(!link_.connected());
  node_.setMetric("serial_reconnects", static_cast<double>(link_.stats().opens));
  node_.setMetric("controller_clock_restarts", static_cast<double>(core_.clockRestarts()));
  node_.setMetric("command_active", core_.commandActive(node_.now()) ? 1.0 : 0.0);
  node_.setMetric("commands_refused_other_robot", static_cast<double>(source_.refusedOtherRobot()));
  node_.setMetric("commands_refused_second_publisher",
                  static_cast<double>(source_.refusedSecondPublisher()));
  node_.status().setWarning("command_source", source_.warning(node_.now()));
}

}  // namespace fieldline::motor_bridge
