#include "services/motor_bridge/bridge_node.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "common/msg/motion_command.hpp"
#include "common/msg/odometry.hpp"

namespace fieldline::motor_bridge {

BridgeNode::BridgeNode(bus::Node& node, const robot::RobotParams& params, BridgeConfig config)
    : node_(node),
      config_(std::move(config)),
      core_(params),
      source_(node.robotId()),
      link_(
          {config_.device, config_.baud_rate, config_.reconnect_interval},
          [this](std::span<const std::uint8_t> bytes) { onBytes(bytes); },
          [this](bool connected) { onLinkState(connected); }) {
  if (!(config_.command_rate > 0.0)) throw std::invalid_argument("command_rate must be positive");
  // A command goes out on the line at the next tick of the command timer: its messages do not
  // wake the bridge, they are handled just before that tick (issue 32: a wake-up less each).
  node_.subscribeDeferred(bus::channels::kMotionCommand,
                          [this, alive = alive_](const motion_command_t& m) {
                            if (*alive) onCommand(m);
                          });
  command_period_us_ = static_cast<Utime>(1e6 / config_.command_rate);
  command_tick_ = node_.every(command_period_us_, [this] { onTick(); });
  last_frame_us_ = node_.clock().monotonicNow();
  frame_due_us_ = last_frame_us_ + command_period_us_ - command_period_us_ / 4;
  metrics_tick_ = node_.every(kMicrosPerSecond, [this] { publishMetrics(); });
  // An open serial line is not enough: the controller's samples must flow (a reader stealing the
  // pty's bytes, a stopped simulator).
  node_.requireOutput(
      bus::channels::kOdometry,
      bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kOdometry.name));
  node_.declareIo(bridgeIo(config_.device));
}

bus::ProcessIo bridgeIo(const std::string& device) {
  // Without commands the robot stands still, which is a job done.
  return bus::ProcessIo("motor_bridge")
      .readsIfPresent(bus::channels::kMotionCommand)
      .writes(bus::channels::kOdometry)
      .link("serial", device, bus::Link::Direction::kBoth);
}

BridgeNode::~BridgeNode() {
  stop();  // unwatches the line
  // The node outlives this bridge (a process that rebuilds its bridge, a test): nothing it keeps
  // may call into it. What the bridge declared on it (ODOMETRY's rate, its inputs and outputs)
  // stays: a node that spins on without a bridge reports ODOMETRY below its rate, as it should.
  node_.cancelTimer(command_tick_);
  node_.cancelTimer(metrics_tick_);
  *alive_ = false;
}

void BridgeNode::start() {
  stopped_ = false;
  link_.start();
  if (!link_.connected()) spdlog::warn("{}; retrying", link_.lastError());
}

void BridgeNode::stop() {
  if (stopped_) return;
  stopped_ = true;
  link_.send(core_.stopFrame());
  if (line_watch_) node_.unwatchFd(*line_watch_);
  line_watch_.reset();
  link_.stop();
}

void BridgeNode::onBytes(std::span<const std::uint8_t> bytes) {
  outputs_.clear();
  core_.onBytes(bytes, node_.now(), outputs_);
  for (const auto& o : outputs_) {
    msg::toMessage(o, odometry_);
    node_.publish(bus::channels::kOdometry, odometry_);
    // The robot's speed as its wheels tell it: the status table's headline for this robot.
    node_.setMetric("speed_mps", std::hypot(o.vx, o.vy));
  }
  if (!outputs_.empty()) onSample();
}

void BridgeNode::onSample() {
  const auto& hello = core_.controllerHello();
  if (!hello || static_cast<Utime>(hello->odometry_period_us) != command_period_us_) return;
  const Utime now = node_.clock().monotonicNow();
  const Utime period = command_period_us_;
  const Utime window = period / 4;
  // The schedule toward the sample's phase (the nearest due time), by at most 1/40 period; never
  // later than a period and 1/40 after the last frame, so that samples coming faster than their
  // Hello says cannot push the frames (and the deadline) back without end.
  const Utime phase = ((now - frame_due_us_ + period / 2) % period + period) % period - period / 2;
  frame_due_us_ = std::min(frame_due_us_ + std::clamp(phase, -period / 40, period / 40),
                           std::max(frame_due_us_, last_frame_us_ + period + period / 40));
  if (now >= frame_due_us_ - window) {
    // The MOTION_COMMANDs that waited in their socket first: the frame carries the newest.
    node_.handleDeferred();
    sendCommand();
    // Far behind (a stalled process): start over from now instead of catching up.
    frame_due_us_ = std::max(frame_due_us_ + period, now + period - window);
  }
  // The timer only as the deadline, a quarter period after the next frame is due.
  node_.moveTimer(command_tick_, std::max<Utime>(0, frame_due_us_ + window - now));
}

void BridgeNode::onLinkState(bool connected) {
  // The old descriptor is closed (or replaced): stop waiting on it in either case.
  if (line_watch_) node_.unwatchFd(*line_watch_);
  line_watch_.reset();
  if (!connected) {
    node_.reportError("serial_disconnect", link_.lastError());
    return;
  }
  spdlog::info("serial line {} open", config_.device);
  line_watch_ = node_.watchFd(link_.nativeHandle(), [this] { link_.onReadable(); });
  core_.onConnected();
  link_.send(core_.helloFrame());
}

void BridgeNode::onCommand(const motion_command_t& m) {
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
}

void BridgeNode::onTick() {
  // The frame that no sample brought, a quarter period after it was due (or the tick alone, when
  // no samples pace the frames): the next is due a period later.
  const Utime now = node_.clock().monotonicNow();
  frame_due_us_ = std::max(frame_due_us_ + command_period_us_,
                           now + command_period_us_ - command_period_us_ / 4);
  sendCommand();
}

void BridgeNode::sendCommand() {
  last_frame_us_ = node_.clock().monotonicNow();
  link_.send(core_.commandFrame(node_.now()));
  // Reopens the line when a retry is due, writes what the device did not take before.
  link_.poll();
}

void BridgeNode::publishMetrics() {
  // Malformed frames and rejections from the core go into SERVICE_STATUS.
  std::uint64_t bad_frames = 0;
  for (const auto& [kind, n] : core_.counters()) {
    node_.setMetric(kind + "_total", static_cast<double>(n));
    if (kind.starts_with("serial_")) bad_frames += n;
  }
  if (bad_frames > reported_bad_frames_) {
    node_.reportError("serial_bad_frames", std::to_string(bad_frames - reported_bad_frames_) +
                                               " malformed frames dropped");
    reported_bad_frames_ = bad_frames;
  }
  node_.setMetric("serial_connected", link_.connected() ? 1.0 : 0.0);
  // Without its serial line the bridge cannot do its job: the status says error.
  node_.status().setFault(!link_.connected());
  node_.setMetric("serial_reconnects", static_cast<double>(link_.stats().opens));
  node_.setMetric("serial_frames_dropped", static_cast<double>(link_.stats().frames_dropped));
  node_.setMetric("odometry_samples_lost", static_cast<double>(core_.samplesLost()));
  node_.setMetric("controller_clock_restarts", static_cast<double>(core_.clockRestarts()));
  node_.setMetric("command_active", core_.commandActive(node_.now()) ? 1.0 : 0.0);
  node_.setMetric("commands_refused_other_robot", static_cast<double>(source_.refusedOtherRobot()));
  node_.setMetric("commands_refused_second_publisher",
                  static_cast<double>(source_.refusedSecondPublisher()));
  node_.status().setWarning("command_source", source_.warning(node_.now()));
}

}  // namespace fieldline::motor_bridge
