// The example adapter for a controller that speaks its own text protocol (text_protocol.hpp,
// docs/own-controller.md), as plain logic on times the caller passes in (the node adds LCM, the
// clock and the serial link). It produces the same ODOMETRY the binary bridge does:
//   - O lines (wheel ticks): stamped with the sampling time (the controller's clock mapped onto
//     the host's, ControllerClockMap, minus the robot file's controller_latency), the movement
//     since the previous sample from the wheel kinematics (three or four wheels), the velocity
//     over the controller's interval; a first sample, a controller clock that ran backwards or
//     leapt ahead by more than a second is a resync (STATUS_RESYNC, no movement);
//   - S lines (body velocity, a controller without ticks): ODOMETRY with wheel_count 0, the
//     movement over the interval from the mean of the two velocities;
//   - anything malformed is counted by kind ("text_malformed", "text_wheel_count",
//     "text_overlong", "text_implausible", "text_mixed") and never forwarded.
// Commands: MOTION_COMMAND's normalised velocity (CommandGate) times the robot file's top speeds,
// as a V line in SI units.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/perception/body.hpp"
#include "common/robot/robot_params.hpp"
#include "common/robot/wheel_odometry.hpp"
#include "common/time/clock.hpp"
#include "common/time/controller_clock.hpp"
#include "services/motor_bridge/command_gate.hpp"
#include "services/motor_bridge/text_protocol.hpp"

namespace fieldline::motor_bridge {

class TextBridgeCore {
 public:
  // A controller time step beyond this is a restart of the controller (or lost lines): resync.
  static constexpr std::int64_t kMaxIntervalUs = 1'000'000;
  // Movement faster than this times the robot's top speed is corrupt, not real.
  static constexpr double kImplausibleFactor = 2.0;

  explicit TextBridgeCore(const robot::RobotParams& params);

  // A motion command received at `now`; false (counted) when it is not used.
  bool onCommand(const CommandInput& command, Utime now) {
    return commands_.onCommand(command, now);
  }
  // The line to send at `now`: the current command in SI units, or zero.
  std::string commandLine(Utime now);
  // A zero command that also forgets the current one (on shutdown).
  std::string stopLine();
  // The line was (re)opened: forget a partial line and the tick reference.
  void onConnected();
  // Bytes received at `now`; appends odometry outputs.
  void onBytes(std::span<const std::uint8_t> bytes, Utime now,
               std::vector<perception::OdometryReading>& out);

  const std::map<std::string, std::uint64_t>& counters() const { return counters_; }
  // The last malformed line and why (empty if none yet).
  const std::string& lastError() const { return last_error_; }
  std::uint64_t clockRestarts() const { return clock_.restarts(); }
  bool commandActive(Utime now) const { return commands_.active(now); }

 private:
  struct Sample {
    std::int64_t controller_time_us = 0;
    // O: ticks; S: none, the velocity.
    robot::TickCounts ticks;
    double vx = 0.0, vy = 0.0, omega = 0.0;
    bool resync = false;
    Utime utime = 0;
  };
  void onLine(std::string_view line, Utime now);
  void reject(const std::string& kind, const std::string& what);
  void emit(const Sample& s, std::vector<perception::OdometryReading>& out);

  robot::RobotParams params_;
  ControllerClockMap clock_;
  robot::WheelOdometry odometry_;
  std::map<std::string, std::uint64_t> counters_;
  CommandGate commands_{counters_};
  text::LineSplitter splitter_;
  std::uint64_t overlong_reported_ = 0;
  // Samples of the read being handled, and the last one emitted (the reference).
  std::vector<Sample> pending_;
  std::optional<Sample> last_;
  std::optional<Sample> last_checked_;
  bool resync_ = true;
  std::string last_error_;
};

}  // namespace fieldline::motor_bridge
