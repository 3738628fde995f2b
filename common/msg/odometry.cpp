#include "common/msg/odometry.hpp"

#include <algorithm>

namespace fieldline::msg {

// The bridge's status bits are the message's: a change of either breaks the build here.
static_assert(perception::kOdometryWatchdog == odometry_t::STATUS_WATCHDOG);
static_assert(perception::kOdometryMotorFault == odometry_t::STATUS_MOTOR_FAULT);
static_assert(perception::kOdometryFramesLost == odometry_t::STATUS_FRAMES_LOST);
static_assert(perception::kOdometryResync == odometry_t::STATUS_RESYNC);
static_assert(perception::kOdometryCurrents == odometry_t::STATUS_CURRENTS);
static_assert(perception::kOdometryGyro == odometry_t::STATUS_GYRO);

perception::OdometryReading fromMessage(const odometry_t& m) {
  perception::OdometryReading r;
  r.utime = m.header.utime;
  // validate() keeps wheel_count within 0..4 and the arrays at its size.
  const auto wheels = std::min<std::size_t>(
      static_cast<std::size_t>(std::max<int>(m.wheel_count, 0)), perception::kMaxOdometryWheels);
  for (std::size_t i = 0; i < wheels && i < m.ticks.size(); ++i)
    r.ticks.push_back(m.ticks[i]);
  r.controller_utime = m.controller_utime;
  r.movement = {m.dx, m.dy, m.dphi};
  r.vx = m.vx;
  r.vy = m.vy;
  r.omega = m.omega;
  r.status = m.status;
  if ((m.status & odometry_t::STATUS_CURRENTS) != 0) {
    for (std::size_t i = 0; i < wheels && i < m.wheel_current.size(); ++i)
      r.wheel_current.push_back(m.wheel_current[i]);
  }
  r.gyro_dphi = m.gyro_dphi;
  return r;
}

void toMessage(const perception::OdometryReading& r, odometry_t& m) {
  m.header.utime = r.utime;
  m.wheel_count = static_cast<std::int32_t>(r.ticks.size());
  m.ticks.assign(r.ticks.begin(), r.ticks.end());
  m.controller_utime = r.controller_utime;
  m.dx = r.movement.dx;
  m.dy = r.movement.dy;
  m.dphi = r.movement.dphi;
  m.vx = r.vx;
  m.vy = r.vy;
  m.omega = r.omega;
  m.status = r.status;
  // Zeros without currents (STATUS_CURRENTS says whether they are valid).
  m.wheel_current.assign(r.ticks.size(), 0.0f);
  for (std::size_t i = 0; i < r.wheel_current.size() && i < m.wheel_current.size(); ++i)
    m.wheel_current[i] = r.wheel_current[i];
  m.gyro_dphi = r.gyro_dphi;
}

}  // namespace fieldline::msg
