#include "common/robot/wheel_odometry.hpp"

#include <numbers>
#include <stdexcept>
#include <string>

namespace fieldline::robot {

std::int32_t tickDelta(std::int32_t newer, std::int32_t older) {
  // Modular subtraction in unsigned arithmetic, read back as a signed step.
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(newer) -
                                   static_cast<std::uint32_t>(older));
}

WheelOdometry::WheelOdometry(const RobotParams& params)
    : kinematics_(params.wheels), ticks_per_revolution_(params.ticksPerWheelRevolution()) {}

WheelVector WheelOdometry::wheelRotations(const TickDeltas& tick_delta) const {
  const double per_tick = 2.0 * std::numbers::pi / ticks_per_revolution_;
  WheelVector out(static_cast<Eigen::Index>(tick_delta.size()));
  for (std::size_t i = 0; i < tick_delta.size(); ++i)
    out[static_cast<Eigen::Index>(i)] = static_cast<double>(tick_delta[i]) * per_tick;
  return out;
}

geometry::Movement WheelOdometry::movement(const TickDeltas& tick_delta) const {
  return kinematics_.movementFromWheelRotations(wheelRotations(tick_delta));
}

std::optional<geometry::Movement> WheelOdometry::update(const TickCounts& accumulated) {
  if (static_cast<int>(accumulated.size()) != kinematics_.wheelCount()) {
    throw std::invalid_argument("wheel odometry: " + std::to_string(accumulated.size()) +
                                " tick counts for " + std::to_string(kinematics_.wheelCount()) +
                                " wheels");
  }
  if (!last_) {
    last_ = accumulated;
    return std::nullopt;
  }
  TickDeltas delta;
  for (std::size_t i = 0; i < accumulated.size(); ++i)
    delta.push_back(tickDelta(accumulated[i], (*last_)[i]));
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
