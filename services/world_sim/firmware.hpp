// The motor controller's firmware, emulated: what the microcontroller on the robot does with
// the bytes of the serial protocol (docs/serial-protocol.md). Plain logic on simulated time; the
// pseudo-terminal around it is in pseudo_terminal.hpp.
//
// It decodes velocity commands, lets each act on the motors `controller_latency` after it
// arrived, stops the motors when no valid command came for `watchdog_timeout`, answers a host's
// Hello, and samples the accumulated wheel ticks with its own clock at the odometry rate.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "common/robot/motor_model.hpp"
#include "common/robot/robot_params.hpp"
#include "common/robot/wheel_odometry.hpp"
#include "common/serial/protocol.hpp"

namespace fieldline::world_sim {

inline constexpr std::uint16_t kEmulatorFirmwareVersion = 0x0100;

// The controller's current measurement, emulated from the simulated wheel: each wheel's motor
// delivers the force that accelerates its share of the robot (m / n for n wheels times the
// wheel's acceleration over the sample period) plus the floor's friction against the wheel's slip
// (surface speed minus the body's ground speed at the wheel, mean over the period), which grows
// with the slip and saturates at the friction limit mu m g / n. Current = force * wheel radius /
// (gear ratio * torque constant) + white measurement noise. In free driving the slip is the
// carpet's small random slip; a robot pushed or twisted by another one slips at up to metres per
// second and its currents sit at the friction limit.
struct CurrentModel {
  bool enabled = true;
  // Friction coefficient of wheel on carpet.
  double friction_coefficient = 0.5;
  // Slip speed at which the friction reaches its limit [m/s].
  double saturation_slip_speed = 1.0;
  // Standard deviation of the measured current [A].
  double noise_a = 0.05;
};

// What the simulator tells the emulated controller about its wheels at a sample (world.hpp).
struct WheelState {
  // Wheel speeds as the encoders see them [m/s], one per wheel.
  robot::WheelVector speeds;
  // Accumulated slip per wheel [m] (RobotTruth::wheel_slip).
  robot::WheelVector slip;
};

// The controller's yaw-rate gyro, emulated from the simulator's true body rotation rate
// (RobotTruth::omega, so the twist of a collision that the wheels miss is in it) with the error
// model of the robot file's `gyro:` section (robot::GyroParams): a scale-factor error and a
// constant bias drawn once per start, a bias random walk, white rate noise of
// noise_density * sqrt(bandwidth) per rate sample, saturation at +-range and quantisation to the
// LSB. The firmware integrates every rate sample (one per physics step) into an angle and sends
// the accumulated angle with each odometry sample: the host's difference is the rotation over
// the period, not one rate sample.
class GyroModel {
 public:
  GyroModel(const robot::GyroParams& params, std::uint64_t seed);
  // One rate sample of `dt` seconds while the body turns at `true_rate` [rad/s].
  void step(double true_rate, double dt);
  // The integrated angle since the start [rad].
  double angle() const { return angle_; }
  // This start's errors: bias [rad/s] (now, after its random walk) and scale error [1].
  double bias() const { return bias_; }
  double scaleError() const { return scale_error_; }
  std::uint64_t samples() const { return samples_; }
  // Rate samples that hit the range.
  std::uint64_t saturated() const { return saturated_; }

 private:
  robot::GyroParams params_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  double bias_ = 0.0;
  double scale_error_ = 0.0;
  double angle_ = 0.0;
  std::uint64_t samples_ = 0;
  std::uint64_t saturated_ = 0;
};

struct FirmwareStats {
  std::uint64_t commands_accepted = 0;
  std::uint64_t samples_sent = 0;
  std::uint64_t hellos_answered = 0;
  std::uint64_t watchdog_stops = 0;
};

class FirmwareEmulator {
 public:
  // `clock_offset_us`: the controller clock's reading at simulated time 0 (it has its own clock).
  FirmwareEmulator(const robot::RobotParams& params, std::uint64_t clock_offset_us,
                   CurrentModel currents = {});

  // Bytes from the host, arriving at simulated time `t` [s]. Replies (Hello, error reports) are
  // appended to `reply`.
  void receive(std::span<const std::uint8_t> bytes, double t, std::vector<std::uint8_t>& reply);
  // The command the motors act on at `t`: the latest one whose latency has passed, or zero once
  // the watchdog has expired.
  robot::NormalizedCommand motorCommand(double t);
  bool watchdogStopped(double t) const;
  // Appends the odometry frame for ticks sampled at `t` (one per wheel: type 0x20 for three
  // wheels, 0x21 for four); with `wheels`, and the current model enabled, the frame carries the
  // mean wheel currents since the previous sample.
  void sample(double t, const robot::TickCounts& ticks, std::vector<std::uint8_t>& out,
              const WheelState* wheels = nullptr);
  // The currents (CurrentModel) for wheels in state `now` after `previous`, `dt` seconds apart,
  // with noise `noise_a` (one standard normal draw per wheel) [A].
  static robot::WheelVector wheelCurrents(const robot::RobotParams& params,
                                          const CurrentModel& model, const WheelState& previous,
                                          const WheelState& now, double dt,
                                          const robot::WheelVector& unit_noise);
  // One physics step of `dt` seconds at the body's true rotation rate [rad/s]: the gyro (when the
  // robot has one) takes its rate sample and integrates it.
  void gyroStep(double true_rate, double dt);
  const std::optional<GyroModel>& gyro() const { return gyro_; }
  // The serial line was replaced: forget a partial frame.
  void lineReset() { decoder_.reset(); }

  const FirmwareStats& stats() const { return stats_; }
  const serial::DecoderStats& decoderStats() const { return decoder_.stats(); }
  std::uint64_t controllerTimeUs(double t) const;

 private:
  struct Pending {
    double apply_at = 0.0;
    robot::NormalizedCommand command;
  };

  robot::RobotParams params_;
  std::uint64_t clock_offset_us_;
  CurrentModel currents_;
  std::optional<WheelState> last_wheels_;
  double last_wheels_t_ = 0.0;
  std::mt19937_64 noise_rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::optional<GyroModel> gyro_;
  serial::Decoder decoder_;
  std::vector<serial::Message> messages_;
  std::deque<Pending> pending_;
  robot::NormalizedCommand active_;
  // Time the last valid command arrived; negative before the first.
  double last_command_time_ = -1.0;
  std::uint32_t last_command_seq_ = 0;
  std::uint32_t sample_seq_ = 0;
  std::uint64_t bad_frames_reported_ = 0;
  bool was_stopped_ = true;
  FirmwareStats stats_;
};

}  // namespace fieldline::world_sim
