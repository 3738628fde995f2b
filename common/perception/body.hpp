// What the robot's body reports and is told, without LCM: ODOMETRY (motor_bridge -> fusion) and
// MOTION_COMMAND (pilot or behaviour -> motor_bridge). Conversions in common/msg.
#pragma once

#include <cstddef>
#include <cstdint>

#include <boost/container/static_vector.hpp>

#include "common/geometry/geometry.hpp"

namespace fieldline::perception {

// Bits of OdometryReading::status; equal odometry_t's STATUS_ constants (checked at compile
// time in common/msg/odometry.cpp).
inline constexpr std::int32_t kOdometryWatchdog = 1;
inline constexpr std::int32_t kOdometryMotorFault = 2;
inline constexpr std::int32_t kOdometryFramesLost = 4;
inline constexpr std::int32_t kOdometryResync = 8;
inline constexpr std::int32_t kOdometryCurrents = 16;
inline constexpr std::int32_t kOdometryGyro = 32;

// Wheels a robot may have (3 or 4; common/robot's kMaxWheels).
inline constexpr std::size_t kMaxOdometryWheels = 4;
template <typename T>
using PerWheelValues = boost::container::static_vector<T, kMaxOdometryWheels>;

// One odometry sample of the motor controller.
struct OdometryReading {
  // Physical sampling time, µs since the epoch on this robot's clock.
  std::int64_t utime = 0;
  // Accumulated encoder ticks of each wheel (wrapping int32): 3 or 4, or none from a controller
  // that reports only its movement (odometry_t wheel_count 0).
  PerWheelValues<std::int32_t> ticks;
  // The controller's own clock at sampling [µs].
  std::int64_t controller_utime = 0;
  // Movement since the previous sample, robot frame at that sample [m, m, rad].
  geometry::Movement movement;
  // Velocity in the robot frame [m/s, m/s, rad/s].
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;
  // kOdometry* bits.
  std::int32_t status = 0;
  // Mean motor current per wheel over the sample period [A]; valid with kOdometryCurrents
  // (then as many as ticks).
  PerWheelValues<float> wheel_current;
  // Rotation since the previous sample from the controller's gyro [rad CCW], raw (bias and scale
  // error included); valid with kOdometryGyro.
  double gyro_dphi = 0.0;
};

// Who sent a motion command; values equal motion_command_t's SOURCE_ constants.
enum class CommandSource : std::int8_t { kUnknown = 0, kPilot = 1, kBehavior = 2, kManual = 3 };

// A normalised velocity command for the motor bridge.
struct MotionCommand {
  // Time the command was decided, µs since the epoch.
  std::int64_t utime = 0;
  // Robot frame, normalised to [-1, 1] of the robot's top speeds.
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;
  // The command is void after this time [µs since the epoch].
  std::int64_t deadline_utime = 0;
  CommandSource source = CommandSource::kUnknown;
};

}  // namespace fieldline::perception
