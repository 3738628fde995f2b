#include "common/robot/motor_model.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fieldline::robot {

MotorModel::MotorModel(double alpha, double beta, double mass)
    : alpha_(alpha), beta_(beta), mass_(mass) {
  if (!(alpha > 0.0) || !(beta > 0.0) || !(mass > 0.0)) {
    throw std::invalid_argument("motor model: alpha, beta and mass must be positive");
  }
}

MotorModel MotorModel::fromParams(const RobotParams& params) {
  const double beta = params.mass / params.motor.time_constant;
  return MotorModel(beta * params.motor.max_wheel_speed, beta, params.mass);
}

double MotorModel::speedAfter(double v0, double command, double dt) const {
  const double target = steadyStateSpeed(command);
  return target + (v0 - target) * std::exp(-dt / timeConstant());
}

WheelVector MotorModel::speedsAfter(const WheelVector& v0, const WheelVector& commands,
                                    double dt) const {
  const double decay = std::exp(-dt / timeConstant());
  const WheelVector target = commands * (alpha_ / beta_);
  return target + (v0 - target) * decay;
}

namespace {
double clampUnit(double v) {
  return std::isfinite(v) ? std::clamp(v, -1.0, 1.0) : 0.0;
}
}  // namespace

Twist desiredTwist(const NormalizedCommand& command, const RobotParams& params) {
  const bool finite =
      std::isfinite(command.vx) && std::isfinite(command.vy) && std::isfinite(command.omega);
  if (!finite) return {};
  return {clampUnit(command.vx) * params.max_speed, clampUnit(command.vy) * params.max_speed,
          clampUnit(command.omega) * params.max_omega};
}

WheelVector wheelCommands(const NormalizedCommand& command, const RobotParams& params,
                          const OmniKinematics& kinematics) {
  const WheelVector speeds = kinematics.wheelSpeeds(desiredTwist(command, params));
  const double top = params.motor.max_wheel_speed;
  const double largest = speeds.cwiseAbs().maxCoeff();
  const double scale = largest > top ? top / largest : 1.0;
  return speeds * (scale / top);
}

}  // namespace fieldline::robot
