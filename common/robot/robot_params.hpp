// Parameters of an omni-directional robot with three or four wheels at any angles (seed 1.3,
// 4.4, 4.5, 4.8), loaded from config/robot/<name>.yaml. SI units; angles in the robot frame
// (x forward, y left).
#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <boost/container/static_vector.hpp>

#include "common/config/config.hpp"

namespace fieldline::robot {

// A robot drives on three or four omni wheels (the seed's has three; NuBot and others four).
inline constexpr int kMinWheels = 3;
inline constexpr int kMaxWheels = 4;

// One value per wheel, without heap allocation.
template <typename T>
using PerWheel = boost::container::static_vector<T, kMaxWheels>;
// A column of one value per wheel (wheel speeds, rotations, commands) for the kinematics.
using WheelVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxWheels, 1>;

// One omni wheel: where it touches the floor and how large it is. The wheel drives along the
// tangent (-sin angle, cos angle), i.e. counter-clockwise around the robot centre.
struct WheelGeometry {
  // Direction of the contact point from the robot centre [rad], robot frame.
  double angle = 0.0;
  // Distance of the contact point from the robot centre [m] (L in the seed).
  double distance = 0.0;
  // Effective wheel radius [m] (r_e in the seed).
  double radius = 0.0;
};

using WheelSet = PerWheel<WheelGeometry>;

// The closed-loop motor model of seed eq. 4.45: f = alpha * u - beta * v per wheel.
struct MotorParams {
  // Ground speed of a wheel at full command [m/s].
  double max_wheel_speed = 0.0;
  // Time constant of the wheel speed response to a command step [s].
  double time_constant = 0.0;
  // Motor torque per ampere [N m / A] (optional key; the seed's 90 W motors: about 0.0255): turns
  // the controller's measured wheel currents into wheel forces (through gear and wheel radius).
  double torque_constant = 0.0255;
};

// The yaw-rate gyro on the motor controller board (a MEMS part), as its data sheet describes it:
// the firmware integrates its rate samples into an angle (docs/serial-protocol.md), fusion takes
// its error model for the heading's process noise, and the firmware emulator draws the errors of
// one start from it. Absent in the robot file (`gyro:` missing): the robot has none, `present`
// false, and every consumer uses the wheels' heading.
struct GyroParams {
  bool present = false;
  // Output data rate of the rate samples the firmware integrates [Hz] (the emulator samples at
  // every physics step instead, 400 Hz).
  double sample_rate = 1000.0;
  // Bandwidth of the gyro's low-pass filter [Hz]: the white noise of one rate sample is
  // noise_density * sqrt(bandwidth).
  double bandwidth = 200.0;
  // Rate noise density [rad/s/sqrt(Hz)] (= angle random walk, rad/sqrt(s)).
  double noise_density = 2.6e-4;
  // Spread of the constant bias, drawn once per start [rad/s, one sigma].
  double bias_sigma = 5.2e-3;
  // Bias random walk [rad/s per sqrt(s)].
  double bias_walk = 8.7e-5;
  // Spread of the scale-factor error, drawn once per start [1, one sigma].
  double scale_sigma = 0.005;
  // Measurement range: rates beyond +-range saturate [rad/s].
  double range = 69.8;
  // One LSB of a rate sample [rad/s]; 0: not quantised.
  double lsb = 2.13e-3;
};

// How the simulated robot differs from its nominal model: odometry does not know these.
struct SimulationErrors {
  // True radius = nominal * (1 + error), per wheel (as many as the robot has wheels).
  PerWheel<double> wheel_radius_error;
  // True contact-point angle = nominal + error [rad], per wheel.
  PerWheel<double> wheel_angle_error;
  // Relative white noise on each wheel's contact speed [1/sqrt(s)].
  double slip_noise = 0.0;
  // Random rotation rate while driving [rad/s per m/s of speed].
  double rotation_noise = 0.0;
  // Random rotation rate while in contact with an obstacle [rad/s].
  double collision_rotation_noise = 0.0;
};

struct RobotParams {
  std::string name;
  // [kg]
  double mass = 0.0;
  // Body radius for collisions [m].
  double radius = 0.0;
  // Speeds that normalised commands of 1.0 stand for [m/s], [rad/s].
  double max_speed = 0.0;
  double max_omega = 0.0;
  // Command-to-motor delay of the controller [s].
  double controller_latency = 0.0;
  // Odometry sample rate of the controller [Hz].
  double odometry_rate = 0.0;
  // Motors stop after this long without a valid command [s].
  double watchdog_timeout = 0.0;
  // Three or four wheels, in the order of the controller's ticks.
  WheelSet wheels;
  int pulses_per_motor_revolution = 0;
  int gear_ratio = 0;
  MotorParams motor;
  GyroParams gyro;
  SimulationErrors simulation;

  int wheelCount() const { return static_cast<int>(wheels.size()); }
  // Encoder ticks per wheel revolution (768 on the seed's robot).
  int ticksPerWheelRevolution() const { return pulses_per_motor_revolution * gear_ratio; }
  // The wheels as they really are in the simulator (nominal plus systematic errors).
  WheelSet trueWheels() const;
};

// Reads a robot file's root map; throws config::Error (file:line: key) on anything wrong.
RobotParams loadRobotParams(const config::Node& root);
// Loads config/robot/<name>.yaml (or a path).
RobotParams loadRobotPreset(const std::string& name_or_path);

}  // namespace fieldline::robot
