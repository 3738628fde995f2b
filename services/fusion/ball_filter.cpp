#include "services/fusion/ball_filter.hpp"

#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace fieldline::fusion {

const char* toString(BallRejection r) {
  switch (r) {
    case BallRejection::kNone:
      return "none";
    case BallRejection::kNotVisible:
      return "ball_not_visible";
    case BallRejection::kNotFinite:
      return "ball_not_finite";
    case BallRejection::kOutOfOrder:
      return "ball_out_of_order";
    case BallRejection::kTooFar:
      return "ball_too_far";
    case BallRejection::kOutlier:
      return "ball_outlier";
    case BallRejection::kPoseUnconfirmed:
      return "ball_pose_unconfirmed";
  }
  return "unknown";
}

namespace {

// A sighting's covariance in the field frame at `z`: its own (radial / tangential, with the
// floor added) plus the robot's pose uncertainty carried through the transform.
Eigen::Matrix2d fieldCovariance(const perception::BallSighting& s, const geometry::Pose2& pose,
                                const Eigen::Vector2d& z, const Eigen::Matrix3d& pose_covariance,
                                double floor_m) {
  const double bearing = std::atan2(s.y, s.x) + pose.phi;
  const Eigen::Matrix2d rot = Eigen::Rotation2Dd(bearing).toRotationMatrix();
  const double floor2 = floor_m * floor_m;
  Eigen::Matrix2d r = rot *
                      Eigen::Vector2d(s.sigma_radial * s.sigma_radial + floor2,
                                      s.sigma_tangential * s.sigma_tangential + floor2)
                          .asDiagonal() *
                      rot.transpose();
  Eigen::Matrix<double, 2, 3> j;
  j << 1, 0, -(z.y() - pose.y), 0, 1, z.x() - pose.x;
  return r + j * pose_covariance * j.transpose();
}

}  // namespace

BallFilter::BallFilter(BallFilterParams params) : params_(params) {}

void BallFilter::predict(Utime t, Eigen::Vector4d& x, Eigen::Matrix4d& p) const {
  if (t <= utime_) return;
  const double dt = static_cast<double>(t - utime_) * 1e-6;
  // Rolling friction takes a fixed amount of speed per second until the ball stops.
  const double speed = x.tail<2>().norm();
  const double ratio =
      speed > 1e-9 ? std::max(0.0, speed - params_.rolling_deceleration * dt) / speed : 0.0;
  // Distance covered while decelerating: the mean speed over the interval (or until it stops).
  const double stop_time =
      params_.rolling_deceleration > 0 ? speed / params_.rolling_deceleration : dt;
  const double moving = std::min(dt, stop_time);
  const double travel = ratio > 0.0 ? dt * 0.5 * (1.0 + ratio) : 0.5 * moving;
  Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
  f(0, 2) = f(1, 3) = travel;
  f(2, 2) = f(3, 3) = ratio;
  x = f * x;
  // The covariance moves with the constant-velocity Jacobian: friction takes a fixed amount of
  // speed, so a faster or slower ball along its path slows down alike (derivative 1), and a ball
  // at rest may start to roll at any time. (The friction matrix itself has zero velocity terms
  // at rest: a ball restarted at rest could never learn a velocity from its sightings.)
  f(0, 2) = f(1, 3) = dt;
  f(2, 2) = f(3, 3) = 1.0;
  const double density =
      resting_ ? params_.rest_acceleration_density : params_.acceleration_density;
  const double q = density * density;
  Eigen::Matrix4d qm = Eigen::Matrix4d::Zero();
  for (int i = 0; i < 2; ++i) {
    qm(i, i) = q * dt * dt * dt / 3.0;
    qm(i, i + 2) = qm(i + 2, i) = q * dt * dt / 2.0;
    qm(i + 2, i + 2) = q * dt;
  }
  p = f * p * f.transpose() + qm;
}

BallRejection BallFilter::update(const perception::BallSighting& s, const EkfState& robot,
                                 bool confirmed_after) {
  if (!s.visible) return BallRejection::kNotVisible;
  if (!std::isfinite(s.x) || !std::isfinite(s.y) || !std::isfinite(s.sigma_radial) ||
      !std::isfinite(s.sigma_tangential) || s.sigma_radial <= 0.0 || s.sigma_tangential <= 0.0 ||
      !robot.x.allFinite()) {
    return BallRejection::kNotFinite;
  }
  if (initialized_ && s.utime < utime_) return BallRejection::kOutOfOrder;
  // A pose not confirmed lately may be off by a radian (a robot twisted in a collision, its
  // frames gated): its sighting may agree and be fused; one that disagrees makes the estimate
  // invalid (invalid_after_outlier) but neither starts the filter, counts as an outlier nor
  // restarts it.
  const bool confirmed = confirmed_after && poseConfirmed(s.utime, robot);
  const Eigen::Vector2d local(s.x, s.y);
  const double range = local.norm();
  if (range > params_.max_range_m) return BallRejection::kTooFar;

  const geometry::Pose2 pose = robot.pose();
  const Eigen::Vector2d z = geometry::pointRobotToField(pose, local);
  const Eigen::Matrix2d r =
      fieldCovariance(s, pose, z, robot.p.topLeftCorner<3, 3>(), params_.sighting_floor_m);
  // An expired estimate starts again here, valid once a sighting agrees (restart_when_expired).
  const bool expired = initialized_ && params_.restart_when_expired && expiredAt(s.utime);
  if (!initialized_ || expired) {
    if (!confirmed) return BallRejection::kPoseUnconfirmed;
    restart(s.utime, z, r);
    contradicted_ = expired;
    return BallRejection::kNone;
  }
  Eigen::Vector4d x = x_;
  Eigen::Matrix4d p = p_;
  predict(s.utime, x, p);
  const Eigen::Vector2d y = z - x.head<2>();
  const Eigen::Matrix2d sm = p.topLeftCorner<2, 2>() + r;
  const double m2 = y.dot(sm.inverse() * y);
  if (!(m2 <= params_.gate2)) {
    if (!confirmed) {
      // Withholding the estimate is safe whichever is wrong, moving it is not.
      contradicted_ = contradicted_ || params_.invalid_after_outlier;
      return BallRejection::kPoseUnconfirmed;
    }
    const bool confident = s.sigma_radial <= params_.restart_max_sigma_m &&
                           s.sigma_tangential <= params_.restart_max_sigma_m;
    const bool far =
        params_.restart_distance_m > 0.0 && confident && y.norm() > params_.restart_distance_m;
    if (far || ++outliers_in_row_ >= params_.restart_after_outliers) {
      if (far) ++restarts_far_;
      restart(s.utime, z, r);
      return BallRejection::kNone;
    }
    contradicted_ = contradicted_ || params_.invalid_after_outlier;
    outliers_.push_back(Outlier{s.utime, z, r});
    return BallRejection::kOutlier;
  }
  outliers_in_row_ = 0;
  missed_in_row_ = 0;
  contradicted_ = false;
  outliers_.clear();
  Eigen::Matrix<double, 2, 4> h = Eigen::Matrix<double, 2, 4>::Zero();
  h(0, 0) = h(1, 1) = 1.0;
  const Eigen::Matrix<double, 4, 2> k = p * h.transpose() * sm.inverse();
  x += k * y;
  // A sighting that would make the ball faster than any kick moved with the robot's uncertain
  // pose, not with the ball: start again at it rather than fly off at that speed.
  if (!(x.tail<2>().norm() <= params_.pair_max_speed)) {
    ++too_fast_restarts_;
    outliers_.clear();
    restart(s.utime, z, r);
    return BallRejection::kNone;
  }
  const Eigen::Matrix4d ikh = Eigen::Matrix4d::Identity() - k * h;
  p = ikh * p * ikh.transpose() + k * r * k.transpose();
  x_ = x;
  p_ = 0.5 * (p + p.transpose());
  utime_ = s.utime;
  last_seen_ = s.utime;
  // The model for what comes next: at rest while slow and its sightings agree closely.
  resting_ = x_.tail<2>().norm() < params_.rest_speed_mps && m2 <= params_.rest_max_nis;
  return BallRejection::kNone;
}

bool BallFilter::expiredAt(Utime t) const {
  return static_cast<double>(t - last_seen_) * 1e-6 > params_.max_age_s;
}

bool BallFilter::poseConfirmed(Utime t, const EkfState& robot) const {
  if (params_.pose_max_unconfirmed_s <= 0.0) return true;
  if (robot.last_correction_utime == 0) return false;  // never corrected: dead reckoning only
  if (robot.last_correction_utime >= t) return true;
  return static_cast<double>(t - robot.last_correction_utime) * 1e-6 <=
         params_.pose_max_unconfirmed_s;
}

BallRejection BallFilter::missed(Utime t, const EkfState& robot) {
  if (params_.unseen_range_m <= 0.0 || !initialized_ || contradicted_ || t < utime_ ||
      !robot.x.allFinite()) {
    return BallRejection::kNone;
  }
  if (!poseConfirmed(t, robot)) return BallRejection::kPoseUnconfirmed;
  Eigen::Vector4d x = x_;
  Eigen::Matrix4d p = p_;
  predict(t, x, p);
  const double range = std::hypot(x[0] - robot.x[0], x[1] - robot.x[1]);
  if (!(range <= params_.unseen_range_m)) {
    missed_in_row_ = 0;
    return BallRejection::kNone;
  }
  if (++missed_in_row_ >= params_.unseen_frames) {
    contradicted_ = true;
    ++unseen_invalidations_;
  }
  return BallRejection::kNone;
}

bool BallFilter::fitRow(Utime t, const Eigen::Vector2d& z, const Eigen::Matrix2d& r,
                        Eigen::Vector2d& v, Eigen::Matrix2d& pv, Eigen::Matrix2d& pxv) const {
  // The outliers of the row that are recent enough, and the sighting that restarts.
  std::vector<Outlier> row;
  for (const Outlier& o : outliers_) {
    if (o.utime < t && static_cast<double>(t - o.utime) * 1e-6 <= params_.pair_max_age_s) {
      row.push_back(o);
    }
  }
  row.push_back(Outlier{t, z, r});
  if (row.size() < 2 || static_cast<int>(row.size()) < params_.fit_min_sightings) return false;
  // Weighted least squares of a straight path through the row, per axis: position at t and
  // velocity, each sighting weighted by its mean variance.
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d rhs = Eigen::Matrix2d::Zero();  // column per axis
  for (const Outlier& o : row) {
    const double dt = static_cast<double>(o.utime - t) * 1e-6;
    const double w = 2.0 / o.r.trace();
    const Eigen::Vector2d a(1.0, dt);
    normal += w * a * a.transpose();
    rhs.col(0) += w * a * o.z.x();
    rhs.col(1) += w * a * o.z.y();
  }
  if (std::abs(normal.determinant()) < 1e-18) return false;
  const Eigen::Matrix2d cov = normal.inverse();  // (position, velocity) of one axis
  const Eigen::Matrix2d sol = cov * rhs;
  const Eigen::Vector2d vel(sol(1, 0), sol(1, 1));
  if (!(vel.norm() <= params_.pair_max_speed)) return false;
  // The sightings must lie on that path (false sightings in a row do not make a kick).
  double chi2 = 0.0;
  for (const Outlier& o : row) {
    const double dt = static_cast<double>(o.utime - t) * 1e-6;
    const Eigen::Vector2d res = o.z - Eigen::Vector2d(sol(0, 0), sol(0, 1)) - vel * dt;
    chi2 += res.dot(o.r.inverse() * res);
  }
  // chi^2 with 2 (n - 2) degrees of freedom at 99.9 %, roughly 4 + 7 per extra sighting.
  if (row.size() > 2 && chi2 > 4.0 + 7.0 * static_cast<double>(2 * (row.size() - 2))) return false;
  v = vel;
  // The fit's velocity variance, plus the deceleration the interval hides.
  const double span = static_cast<double>(t - row.front().utime) * 1e-6;
  const double slack = params_.rolling_deceleration + params_.acceleration_density;
  pv = Eigen::Matrix2d::Identity() * (cov(1, 1) + slack * slack * span);
  pxv = Eigen::Matrix2d::Identity() * cov(0, 1);
  return true;
}

void BallFilter::restart(Utime t, const Eigen::Vector2d& z, const Eigen::Matrix2d& r) {
  Eigen::Vector2d v = Eigen::Vector2d::Zero();
  Eigen::Matrix2d pv =
      Eigen::Matrix2d::Identity() * (params_.restart_speed_sigma * params_.restart_speed_sigma);
  Eigen::Matrix2d pxv = Eigen::Matrix2d::Zero();
  if (params_.velocity_from_pair && initialized_ && fitRow(t, z, r, v, pv, pxv)) {
    ++restarts_with_velocity_;
  }
  initialized_ = true;
  x_ << z, v;
  p_.setZero();
  p_.topLeftCorner<2, 2>() = r;
  p_.bottomRightCorner<2, 2>() = pv;
  p_.topRightCorner<2, 2>() = pxv;
  p_.bottomLeftCorner<2, 2>() = pxv.transpose();
  utime_ = t;
  last_seen_ = t;
  outliers_in_row_ = 0;
  missed_in_row_ = 0;
  contradicted_ = false;
  resting_ = false;
  outliers_.clear();
}

void BallFilter::mirrorThroughCentre() {
  // Position and velocity change sign; the covariance is unchanged by a turn of pi.
  x_ = -x_;
  for (Outlier& o : outliers_)
    o.z = -o.z;
}

perception::BallEstimate BallFilter::estimate(Utime t) const {
  perception::BallEstimate e;
  e.utime = t;
  if (!initialized_) return e;
  Eigen::Vector4d x = x_;
  Eigen::Matrix4d p = p_;
  predict(t, x, p);
  e.valid = static_cast<double>(t - last_seen_) * 1e-6 <= params_.max_age_s && !contradicted_;
  e.x = x[0];
  e.y = x[1];
  e.vx = x[2];
  e.vy = x[3];
  const Eigen::Vector2d v = x.tail<2>();
  Eigen::Matrix2d position = p.topLeftCorner<2, 2>();
  // Only while the ball was seen lately: a ball kicked out of sight (or whose sightings are
  // refused as outliers) must not keep a resting ball's covariance until max_age_s.
  constexpr Utime kRestHoldsPlaceForUs = 200'000;  // six frames at 30 Hz
  if (resting_ && params_.rest_holds_place && t > utime_ &&
      t - last_seen_ <= kRestHoldsPlaceForUs) {
    // A ball at rest stays where it was seen: friction takes its velocity out, so the velocity's
    // uncertainty (which the filter keeps to learn a roll) does not move its place over the
    // time since the sighting; only the resting model's unseen acceleration does.
    const double dt = static_cast<double>(t - utime_) * 1e-6;
    const double q = params_.rest_acceleration_density * params_.rest_acceleration_density;
    position = p_.topLeftCorner<2, 2>() + Eigen::Matrix2d::Identity() * (q * dt * dt * dt / 3.0);
  }
  e.covariance = position + params_.stamp_sigma_s * params_.stamp_sigma_s * v * v.transpose();
  e.last_seen_utime = last_seen_;
  return e;
}

}  // namespace fieldline::fusion
