// The motor_bridge process's bus side: MOTION_COMMAND in, velocity frames out on the serial line
// at the command rate; odometry frames in, ODOMETRY out, stamped with the sampling time.
//
// The serial line is a SerialLink this class owns. The bus node's event loop waits on the line's
// file descriptor next to LCM's (Node::watchFd) and has the link read what arrived, in one read;
// a command frame is written when the command timer (50 Hz) ticks, and that tick also reopens a
// lost line when a retry is due. So the process sleeps until bytes, a message or a timer are due:
// no polling loop, no second reactor (issue 32).
//
// When the controller samples at the command rate (its Hello's odometry period is the command
// period), the command tick moves to the samples: the frame goes out in the same wake-up as the
// sample that the bridge reads and publishes (one wake-up a sample instead of two, issue 32),
// with the newest MOTION_COMMAND. The frames keep a schedule of exactly one per command period,
// which each sample pulls by at most 1/40 period toward its own phase (so it follows the
// controller's clock, and no sample, late or in a burst, adds or removes a frame); a sample from
// a quarter period before a frame is due brings it, the timer sends it a quarter period after
// it was due should no sample come. Frames are then 0.5 to 1.5 periods apart, one per period
// on average; without samples the timer alone, every period, as before.
#pragma once

#include <cstdint>
#include <memory>
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

namespace fieldline::motor_bridge {

// What the motor bridge reads and writes with the controller on `device`
// (fieldline-motor-bridge --print-io).
bus::ProcessIo bridgeIo(const std::string& device);

class BridgeNode {
 public:
  // Subscribes MOTION_COMMAND and sets the timers on `node`; opens the line with start().
  // Throws std::invalid_argument for a command rate that is not positive.
  BridgeNode(bus::Node& node, const robot::RobotParams& params, BridgeConfig config);
  // Sends a stop frame and closes the line (stop()), and cancels its timers: the node may spin on
  // without it. Its MOTION_COMMAND subscription stays on the node (bus::Node cannot remove one)
  // but calls nothing once the bridge is gone.
  ~BridgeNode();
  BridgeNode(const BridgeNode&) = delete;
  BridgeNode& operator=(const BridgeNode&) = delete;

  // Opens the serial line now or keeps retrying every reconnect_interval.
  void start();
  // Leaves the robot standing (a zero command, not driving on until the controller's watchdog
  // fires) and closes the line.
  void stop();

  const SerialLink& link() const { return link_; }
  const BridgeCore& core() const { return core_; }

 private:
  void onBytes(std::span<const std::uint8_t> bytes);
  void onLinkState(bool connected);
  void onCommand(const motion_command_t& m);
  void sendCommand();
  // The command timer: the frame that no sample brought in time.
  void onTick();
  // The controller's sample(s) arrived: the frame now when it is (nearly) due.
  void onSample();
  void publishMetrics();

  bus::Node& node_;
  BridgeConfig config_;
  BridgeCore core_;
  // Which MOTION_COMMANDs may drive the robot (its own robot id, one publisher).
  CommandSource source_;
  SerialLink link_;
  std::optional<bus::Node::WatchId> line_watch_;
  std::vector<OdometryOutput> outputs_;
  odometry_t odometry_{};
  std::uint64_t reported_bad_frames_ = 0;
  bool stopped_ = false;
  Utime command_period_us_ = 0;
  bus::Node::TimerId command_tick_ = 0;
  bus::Node::TimerId metrics_tick_ = 0;
  // Whether this bridge still exists, for the subscription the node keeps after it.
  std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
  // Monotonic time the next command frame is due (the schedule the samples pull).
  Utime frame_due_us_ = 0;
  // When the last command frame went out (monotonic): bounds how far samples move the schedule.
  Utime last_frame_us_ = 0;
};

}  // namespace fieldline::motor_bridge
