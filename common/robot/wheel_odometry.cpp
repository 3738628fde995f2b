#include "common/robot/wheel_odometry.hpp"

#include <numbers>

namespace fieldline::robot {

std::int32_t tickDelta(std::int32_t newer, std::int32_t older) {
  // Modular subtraction in unsigned arithmetic, read back as a signed step.
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(newer) -
                                   static_cast<std::uint32_t>(older));
}

WheelOdometry::WheelOdometry(const RobotParams& params)
    : kinematics_(params.wheels), ticks_per_revolution_(params.ticksPerWheelRevolution()) {}

Eigen::Vector3d WheelOdometry::wheelRotations(
    const std::array<std::int64_t, kWheelCount>& tick_delta) const {
  const double per_tick = 2.0 * std::numbers::pi / ticks_per_revolution_;
  return Eigen::Vector3d(static_cast<double>(tick_delta[0]), static_cast<double>(tick_delta[1]),
                         static_cast<double>(tick_delta[2])) *
         per_tick;
}

geometry::Movement WheelOdometry::movement(
    const std::array<std::int64_t, kWheelCount>& tick_delta) const {
  return kinematics_.movementFromWheelRotations(wheelRotations(tick_delta));
}

std::optional<geometry::Movement> WheelOdometry::update(const TickCounts& accumulated) {
  if (!last_) {
    last_ = accumulated;
    return std::nullopt;
  }
  std::array<std::int64_t, kWheelCount> delta{};
  for (int i = 0; i < kWheelCount; ++i)
    delta[i] = tickDelta(accumulated[i], (*last_)[i]);
  last_ = accumulated;
  const geometry::Movement m = movement(delta);
  pose_ = geometry::applyMovement(pose_, m);
  return m;
}

void WheelOdometry::reset(const geometry::Pose2& start) {
  last_.reset();
  pose_ = start;
}

}  // namespace fieldline::robot
