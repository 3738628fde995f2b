#include "common/msg/odometry.hpp"

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
  for (int i = 0; i < 3; ++i)
    r.ticks[static_cast<std::size_t>(i)] = m.ticks[i];
  r.controller_utime = m.controller_utime;
  r.movement = {m.dx, m.dy, m.dphi};
  r.vx = m.vx;
  r.vy = m.vy;
  r.omega = m.omega;
  r.status = m.status;
  for (std::size_t i = 0; i < 3; ++i)
    r.wheel_current[i] = m.wheel_current[i];
  r.gyro_dphi = m.gyro_dphi;
  return r;
}

void toMessage(const perception::OdometryReading& r, odometry_t& m) {
  m.header.utime = r.utime;
  for (int i = 0; i < 3; ++i)
    m.ticks[i] = r.ticks[static_cast<std::size_t>(i)];
  m.controller_utime = r.controller_utime;
  m.dx = r.movement.dx;
  m.dy = r.movement.dy;
  m.dphi = r.movement.dphi;
  m.vx = r.vx;
  m.vy = r.vy;
  m.omega = r.omega;
  m.status = r.status;
  for (std::size_t i = 0; i < 3; ++i)
    m.wheel_current[i] = r.wheel_current[i];
  m.gyro_dphi = r.gyro_dphi;
}

}  // namespace fieldline::msg
