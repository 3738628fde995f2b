#include "common/msg/estimates.hpp"

#include "common/msg/row_major.hpp"

namespace fieldline::msg {

using perception::LocalizationStatus;
static_assert(static_cast<int>(LocalizationStatus::kUnknown) == robot_state_t::STATUS_UNKNOWN);
static_assert(static_cast<int>(LocalizationStatus::kSearching) == robot_state_t::STATUS_SEARCHING);
static_assert(static_cast<int>(LocalizationStatus::kTracking) == robot_state_t::STATUS_TRACKING);
static_assert(static_cast<int>(LocalizationStatus::kOdometryOnly) ==
              robot_state_t::STATUS_ODOMETRY_ONLY);

perception::RobotEstimate fromMessage(const robot_state_t& m) {
  perception::RobotEstimate e;
  e.utime = m.header.utime;
  e.pose = {m.x, m.y, m.phi};
  e.vx = m.vx;
  e.vy = m.vy;
  e.omega = m.omega;
  e.covariance = fromRowMajor<3>(m.covariance);
  e.status = static_cast<LocalizationStatus>(m.status);
  e.since_vision_us = m.since_vision_us;
  e.twin_ambiguous = m.twin_ambiguous != 0;
  return e;
}

void toMessage(const perception::RobotEstimate& e, robot_state_t& m) {
  m.header.utime = e.utime;
  m.x = e.pose.x;
  m.y = e.pose.y;
  m.phi = e.pose.phi;
  m.vx = e.vx;
  m.vy = e.vy;
  m.omega = e.omega;
  toRowMajor<3>(e.covariance, m.covariance);
  m.status = static_cast<std::int8_t>(e.status);
  m.since_vision_us = e.since_vision_us;
  m.twin_ambiguous = e.twin_ambiguous ? 1 : 0;
}

perception::BallEstimate fromMessage(const ball_state_t& m) {
  perception::BallEstimate e;
  e.utime = m.header.utime;
  e.valid = m.valid;
  e.x = m.x;
  e.y = m.y;
  e.vx = m.vx;
  e.vy = m.vy;
  e.covariance = fromRowMajor<2>(m.covariance);
  e.last_seen_utime = m.last_seen_utime;
  return e;
}

void toMessage(const perception::BallEstimate& e, ball_state_t& m) {
  m.header.utime = e.utime;
  m.valid = e.valid;
  m.x = e.x;
  m.y = e.y;
  m.vx = e.vx;
  m.vy = e.vy;
  toRowMajor<2>(e.covariance, m.covariance);
  m.last_seen_utime = e.last_seen_utime;
}

perception::BallSighting fromMessage(const ball_observation_t& m) {
  perception::BallSighting s;
  s.utime = m.header.utime;
  s.visible = m.visible;
  s.u = m.u;
  s.v = m.v;
  s.x = m.x;
  s.y = m.y;
  s.sigma_radial = m.sigma_radial;
  s.sigma_tangential = m.sigma_tangential;
  s.cells = m.cells;
  s.confidence = m.confidence;
  return s;
}

void toMessage(const perception::BallSighting& s, ball_observation_t& m) {
  m.header.utime = s.utime;
  m.visible = s.visible;
  // An unseen ball carries zeros, never stale numbers.
  m.u = static_cast<float>(s.visible ? s.u : 0.0);
  m.v = static_cast<float>(s.visible ? s.v : 0.0);
  m.x = static_cast<float>(s.visible ? s.x : 0.0);
  m.y = static_cast<float>(s.visible ? s.y : 0.0);
  m.sigma_radial = static_cast<float>(s.visible ? s.sigma_radial : 0.0);
  m.sigma_tangential = static_cast<float>(s.visible ? s.sigma_tangential : 0.0);
  m.cells = s.visible ? s.cells : 0;
  m.confidence = static_cast<float>(s.visible ? s.confidence : 0.0);
}

}  // namespace fieldline::msg
