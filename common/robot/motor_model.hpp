// The closed-loop motor model of seed 4.5: each wheel pushes the robot with
//     f = alpha * u - beta * v                                   (eq. 4.45)
// where u in [-1, 1] is the wheel's normalised command and v its ground speed, and the wheel
// accelerates with a = f / m (eq. 4.46). So each wheel speed is a first-order system with time
// constant tau = m / beta that settles at v = alpha / beta * u.
#pragma once

#include <Eigen/Core>

#include "common/robot/omni_kinematics.hpp"
#include "common/robot/robot_params.hpp"

namespace fieldline::robot {

class MotorModel {
 public:
  // alpha [N], beta [kg/s], mass [kg]; all positive.
  MotorModel(double alpha, double beta, double mass);
  // beta = mass / time_constant, alpha = beta * max_wheel_speed.
  static MotorModel fromParams(const RobotParams& params);

  double alpha() const { return alpha_; }
  double beta() const { return beta_; }
  double mass() const { return mass_; }
  double timeConstant() const { return mass_ / beta_; }

  // Eq. 4.45 [N].
  double force(double command, double speed) const { return alpha_ * command - beta_ * speed; }
  // Speed a constant command settles at [m/s].
  double steadyStateSpeed(double command) const { return alpha_ / beta_ * command; }
  // The exact solution of m dv/dt = alpha u - beta v after `dt` seconds from speed `v0`,
  // so the result does not depend on the simulator's step size.
  double speedAfter(double v0, double command, double dt) const;
  // The same for every wheel at once.
  WheelVector speedsAfter(const WheelVector& v0, const WheelVector& commands, double dt) const;

 private:
  double alpha_;
  double beta_;
  double mass_;
};

// A normalised motion command: velocities relative to max_speed / max_omega, each in [-1, 1].
struct NormalizedCommand {
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;
};

// What the controller does with a command (seed 4.5): the desired body twist
// (vx * max_speed, vy * max_speed, omega * max_omega), the wheel speeds it needs, and from them
// the normalised wheel commands u_i = v_i / max_wheel_speed. When a wheel would exceed its top
// speed, all wheels are scaled down together so the direction of motion is kept.
// Inputs outside [-1, 1] are clamped; non-finite inputs give zero commands.
WheelVector wheelCommands(const NormalizedCommand& command, const RobotParams& params,
                          const OmniKinematics& kinematics);

// The body twist a command asks for (clamped as above), before wheel saturation.
Twist desiredTwist(const NormalizedCommand& command, const RobotParams& params);

}  // namespace fieldline::robot
