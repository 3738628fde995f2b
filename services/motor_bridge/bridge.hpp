// What the motor bridge does between the bus and the serial line, as plain logic on times the
// caller passes in (the node adds LCM, the clock and the serial link):
//   - motion commands in: NaN rejected, values clamped to [-1, 1], expired ones ignored; at the
//     command rate the current command (or zero once it expired) goes out as a frame;
//   - bytes in: decoded; odometry samples become Odometry outputs stamped with the physical
//     sampling time: the controller's own time mapped onto the host clock (ControllerClockMap:
//     the low envelope of receive - controller time, minus the controller latency), so the serial
//     link's jitter stays out of the stamp; with the movement since the
//     previous sample from the wheel kinematics, and the gyro's rotation since the previous
//     sample when the controller sends its angle; malformed frames are counted, never forwarded.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/config/config.hpp"
#include "common/perception/body.hpp"
#include "common/robot/robot_params.hpp"
#include "common/robot/wheel_odometry.hpp"
#include "common/serial/protocol.hpp"
#include "common/time/clock.hpp"
#include "common/time/controller_clock.hpp"
#include "services/motor_bridge/command_gate.hpp"

namespace fieldline::motor_bridge {

struct BridgeConfig {
  // Serial device, e.g. /dev/ttyUSB0; "{robot}" is replaced by the robot number.
  std::string device;
  unsigned baud_rate = 115200;
  // [s]
  double reconnect_interval = 0.25;
  // Commands per second sent to the controller (keeps its watchdog fed).
  double command_rate = 50.0;
};

// Reads config/robot/motor_bridge.yaml.
BridgeConfig loadBridgeConfig(const config::Node& root);
// `device` with "{robot}" replaced.
std::string deviceForRobot(const std::string& device, int robot);

// Odometry out of one sample, with the perception::kOdometry* status bits.
using OdometryOutput = perception::OdometryReading;

class BridgeCore {
 public:
  // No command drives the robot longer than this after it arrived, whatever its deadline says.
  static constexpr Utime kMaxCommandLifetimeUs = CommandGate::kMaxCommandLifetimeUs;
  // A seq jump beyond this (1 s of samples at 50 Hz) means the controller restarted: resync.
  static constexpr std::uint32_t kMaxSampleGap = 50;
  // A controller time beyond this (2^53 µs, 285 years) is refused
  // ("odometry_controller_time_absurd"): it would overflow the signed clock arithmetic.
  static constexpr std::uint64_t kMaxControllerTimeUs = std::uint64_t{1} << 53;
  // Movement faster than this times the robot's top speed is corrupt, not real.
  static constexpr double kImplausibleFactor = 2.0;

  explicit BridgeCore(const robot::RobotParams& params);

  // A motion command received at `now`. Returns false (and counts why) when it is not used.
  bool onCommand(const CommandInput& command, Utime now);
  // The frame to send at `now`: the current command, or zero when none is valid.
  std::vector<std::uint8_t> commandFrame(Utime now);
  // A zero command that also forgets the current one (on shutdown).
  std::vector<std::uint8_t> stopFrame();
  // Frames to send after (re)connecting: a delimiter to end any partial frame, and a Hello.
  std::vector<std::uint8_t> helloFrame() const;
  // The serial line was (re)opened: forget partial frames and the tick reference.
  void onConnected();
  // Bytes received at `now`; appends odometry outputs.
  void onBytes(std::span<const std::uint8_t> bytes, Utime now, std::vector<OdometryOutput>& out);

  // Rejection and protocol counters, by kind ("command_nan", "command_expired",
  // "serial_crc", ...), since start.
  const std::map<std::string, std::uint64_t>& counters() const { return counters_; }
  const serial::DecoderStats& decoderStats() const { return decoder_.stats(); }
  // The controller's Hello, once received.
  const std::optional<serial::Hello>& controllerHello() const { return controller_hello_; }
  std::uint64_t samplesLost() const { return samples_lost_; }
  // The controller clock's mapping onto the host's: times it started over (a controller restart,
  // a step of the host clock), and its current offset host - controller, µs.
  std::uint64_t clockRestarts() const { return clock_.restarts(); }
  std::optional<std::int64_t> clockOffset() const { return clock_.envelope(); }
  bool commandActive(Utime now) const { return commands_.active(now); }
  // The command the controller is being sent, after clamping (zero if none).
  const CommandInput& currentCommand() const { return commands_.current(); }

 private:
  // The samples of one read that passed the checks, with their resync and stamp.
  struct Checked {
    const serial::OdometrySample* sample;
    bool resync;
    Utime utime;
  };

  void count(const std::string& kind) { ++counters_[kind]; }
  // onBytes' steps, in order. Counts the frames the decoder rejected since `before`, by reason.
  void countRejectedFrames(const serial::DecoderStats& before);
  // Takes note of the controller's Hello and counts its error reports and unexpected messages.
  void countControllerMessages();
  // Fills checked_ with the read's samples that pass the checks, each with whether it starts
  // the tick reference and the clock mapping over, and its stamp.
  void checkAndStampSamples(Utime now);
  // False (counted) for a sample no controller of this robot sends: an absurd clock, another
  // wheel count, the previous sample again.
  bool acceptSample(const serial::OdometrySample& sample,
                    const std::optional<serial::OdometrySample>& last);
  // True when the sample starts over from itself: the first, after a reconnect, the reset flag,
  // or a discontinuity (counted) since `last`.
  bool startsOver(const serial::OdometrySample& sample,
                  const std::optional<serial::OdometrySample>& last);
  // The odometry output of a checked sample (last_sample_ still the one before it).
  OdometryOutput odometryOutput(const Checked& c);
  // The movement, velocities and gyro rotation since last_sample_; movement the motors cannot
  // make is counted and replaced by a resync.
  void addMovementSinceLast(const serial::OdometrySample& sample, OdometryOutput& o);

  robot::RobotParams params_;
  Utime latency_us_;
  ControllerClockMap clock_;
  serial::Decoder decoder_;
  std::vector<serial::Message> messages_;
  robot::WheelOdometry odometry_;
  std::map<std::string, std::uint64_t> counters_;
  CommandGate commands_{counters_};
  std::uint32_t command_seq_ = 0;
  std::optional<serial::OdometrySample> last_sample_;
  bool resync_ = true;
  std::vector<Checked> checked_;
  std::uint64_t samples_lost_ = 0;
  std::optional<serial::Hello> controller_hello_;
};

}  // namespace fieldline::motor_bridge
