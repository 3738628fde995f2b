#include "services/fusion/odometry_layer.hpp"

#include <cmath>
#include <numbers>

namespace fieldline::fusion {

const char* toString(OdometryRejection r) {
  switch (r) {
    case OdometryRejection::kNone:
      return "none";
    case OdometryRejection::kOutOfOrder:
      return "odometry_out_of_order";
    case OdometryRejection::kDuplicate:
      return "odometry_duplicate";
    case OdometryRejection::kJump:
      return "odometry_jump";
    case OdometryRejection::kResync:
      return "odometry_resync";
    case OdometryRejection::kGap:
      return "odometry_gap";
    case OdometryRejection::kWheelCount:
      return "odometry_wheel_count";
    case OdometryRejection::kNotFinite:
      return "odometry_not_finite";
  }
  return "unknown";
}

OdometryLayer::OdometryLayer(const robot::RobotParams& params, OdometryNoise noise)
    : params_(params), noise_(noise), odometry_(params) {
  gyro_max_rate_ = noise_.gyro_max_rate > 0.0 ? noise_.gyro_max_rate : 1.05 * params.gyro.range;
}

double OdometryLayer::gyroVariance(double dphi, double dt_s) const {
  const robot::GyroParams& g = params_.gyro;
  // White rate noise integrates to an angle random walk; each rate sample's quantisation error
  // (uniform over one LSB) too; the scale error is a fraction of the turn.
  const double white = g.noise_density * g.noise_density * std::max(dt_s, 0.0);
  const double quantisation =
      g.lsb * g.lsb / 12.0 * std::max(dt_s, 0.0) / std::max(g.sample_rate, 1.0);
  const double scale = g.scale_sigma * dphi;
  const double extra =
      noise_.gyro_heading_density * noise_.gyro_heading_density * std::max(dt_s, 0.0);
  return white + quantisation + scale * scale + extra;
}

OdometryStep OdometryLayer::stepFor(const robot::TickDeltas& tick_delta, double dt_s) const {
  return stepForTravel(odometry_.wheelRotations(tick_delta).cwiseProduct(kinematics().radii()),
                       dt_s);
}

OdometryStep OdometryLayer::stepForTravel(const robot::WheelVector& ground, double dt_s) const {
  const robot::WheelMatrixInverse& m_inv = kinematics().robotMatrixInverse();
  const robot::WheelVector& radii = kinematics().radii();

  OdometryStep step;
  step.integrated = m_inv * ground;

  // Each wheel's ground travel is uncertain by slip (relative, and white on the contact speed)
  // and by the tick quantisation; the inverse (least squares for four wheels) carries them into
  // the body's movement.
  const double tick_m = 2.0 * std::numbers::pi / odometry_.ticksPerRevolution();
  const double per_sqrt_s = dt_s > 0.0 ? 1.0 / std::sqrt(dt_s) : 0.0;
  robot::WheelVector wheel_var(ground.size());
  for (Eigen::Index i = 0; i < ground.size(); ++i) {
    const double slip = noise_.wheel_relative_sigma * std::abs(ground[i]);
    const double white = noise_.wheel_slip_density * std::abs(ground[i]) * per_sqrt_s;
    const double quantisation = tick_m * radii[i] / std::sqrt(12.0);
    wheel_var[i] = slip * slip + white * white + quantisation * quantisation;
  }
  step.covariance = m_inv * wheel_var.asDiagonal() * m_inv.transpose();

  // Beyond the wheels: the body slides more the further it goes and the more it turns.
  const double distance = step.integrated.head<2>().norm();
  const double turned = std::abs(step.integrated.z());
  const double s_t = noise_.translation_sigma_per_m * distance;
  const double s_r =
      noise_.rotation_sigma_per_rad * turned + noise_.rotation_sigma_per_m * distance;
  const double s_w = noise_.rotation_slip_density * distance * per_sqrt_s;
  step.covariance(0, 0) += s_t * s_t;
  step.covariance(1, 1) += s_t * s_t;
  step.covariance(2, 2) += s_r * s_r + s_w * s_w;
  return step;
}

void OdometryLayer::restartAt(const OdometrySample& sample) {
  last_ = sample;
  pending_gyro_ = 0.0;
  pending_gyro_valid_ = true;
  pending_movement_ = {};
}

std::optional<OdometryRejection> OdometryLayer::noStepReason(const OdometrySample& sample) {
  // Ticks must be one per wheel of the robot file; none means the controller gives its movement.
  const bool has_ticks = !sample.ticks.empty();
  if (has_ticks && static_cast<int>(sample.ticks.size()) != kinematics().wheelCount()) {
    last_.reset();
    return OdometryRejection::kWheelCount;
  }
  if (!has_ticks && !(std::isfinite(sample.movement.dx) && std::isfinite(sample.movement.dy) &&
                      std::isfinite(sample.movement.dphi))) {
    last_.reset();
    return OdometryRejection::kNotFinite;
  }
  if (sample.resync) {
    restartAt(sample);
    return OdometryRejection::kResync;
  }
  if (last_ && last_->ticks.size() != sample.ticks.size()) {
    // The controller switched between ticks and movements: nothing to take a difference of.
    restartAt(sample);
    return OdometryRejection::kWheelCount;
  }
  if (!last_) {
    restartAt(sample);
    return OdometryRejection::kNone;
  }
  if (sample.utime == last_->utime) return OdometryRejection::kDuplicate;
  return std::nullopt;
}

bool OdometryLayer::gyroUsable(const OdometrySample& sample, const char*& rejection) const {
  if (!(sample.has_gyro && noise_.use_gyro && params_.gyro.present)) return false;
  const double since = std::abs(static_cast<double>(sample.utime - last_->utime)) * 1e-6;
  if (!std::isfinite(sample.gyro_dphi)) {
    rejection = "gyro_not_finite";
    return false;
  }
  if (std::abs(sample.gyro_dphi) > gyro_max_rate_ * std::max(since, 0.02)) {
    rejection = "gyro_absurd";
    return false;
  }
  return true;
}

void OdometryLayer::holdOutOfOrder(const OdometrySample& sample, bool gyro_ok) {
  // Time far backwards (controller restart, clock step) starts over from this sample.
  if (static_cast<double>(last_->utime - sample.utime) * 1e-6 > noise_.max_interval_s) {
    restartAt(sample);
    return;
  }
  pending_gyro_ += gyro_ok ? sample.gyro_dphi : 0.0;
  pending_gyro_valid_ = pending_gyro_valid_ && gyro_ok;
  // Without ticks the movement is this sample's own: kept for the next step, like the gyro.
  if (sample.ticks.empty()) {
    pending_movement_ = geometry::concatenate(pending_movement_, sample.movement);
  }
}

robot::WheelVector OdometryLayer::groundTravel(const OdometrySample& sample,
                                               Eigen::Vector3d& integrated) const {
  if (!sample.ticks.empty()) {
    robot::TickDeltas delta;
    for (std::size_t w = 0; w < sample.ticks.size(); ++w)
      delta.push_back(robot::tickDelta(sample.ticks[w], last_->ticks[w]));
    return odometry_.wheelRotations(delta).cwiseProduct(kinematics().radii());
  }
  integrated = robot::integratedTwist(geometry::concatenate(pending_movement_, sample.movement));
  return kinematics().robotMatrix() * integrated;
}

OdometryLayer::Result OdometryLayer::update(const OdometrySample& sample) {
  Result result;
  // The bridge stamps the sample with its physical time (the controller's clock mapped onto the
  // host's, ControllerClockMap): taken as it is.
  last_stamp_ = sample.utime;
  if (const auto reason = noStepReason(sample)) {
    result.rejection = *reason;
    return result;
  }
  // The gyro's value: used only when the robot has a gyro, fusion is told to use it, and it is
  // finite and within what the gyro can measure over the time since the reference.
  const bool gyro_ok = gyroUsable(sample, result.gyro_rejection);
  if (sample.utime < last_->utime) {
    // Stamps jitter with the arrival time: the reference stays, and the next sample's tick
    // difference covers this one's movement (and its gyro rotation is kept for that step).
    holdOutOfOrder(sample, gyro_ok);
    result.rejection = OdometryRejection::kOutOfOrder;
    return result;
  }
  const double gyro_dphi = pending_gyro_ + (gyro_ok ? sample.gyro_dphi : 0.0);
  const bool use_gyro = pending_gyro_valid_ && gyro_ok;
  pending_gyro_ = 0.0;
  pending_gyro_valid_ = true;
  const double dt = static_cast<double>(sample.utime - last_->utime) * 1e-6;
  // Each wheel's ground travel since the reference: from the ticks, or the travel the
  // controller's movement implies (M times its integrated twist).
  Eigen::Vector3d integrated = Eigen::Vector3d::Zero();
  const robot::WheelVector ground = groundTravel(sample, integrated);
  pending_movement_ = {};
  const Utime previous = last_->utime;
  last_ = sample;

  OdometryStep step = stepForTravel(ground, dt);
  if (sample.ticks.empty()) step.integrated = integrated;
  step.t_start = previous;
  step.t_end = sample.utime;
  if (use_gyro) {
    // The heading from the gyro, independent of the wheels' translation.
    step.gyro = true;
    step.integrated.z() = gyro_dphi;
    step.covariance.row(2).setZero();
    step.covariance.col(2).setZero();
    step.covariance(2, 2) = gyroVariance(gyro_dphi, dt);
  }

  // A jump no wheel can make in this time (counter glitch, garbled frame) is not a movement.
  const double max_travel =
      noise_.max_speed_factor * params_.motor.max_wheel_speed * std::max(dt, 0.02);
  if (ground.cwiseAbs().maxCoeff() > max_travel) {
    result.rejection = OdometryRejection::kJump;
    return result;
  }
  if (dt > noise_.max_interval_s) {
    step.has_velocity = false;
    result.rejection = OdometryRejection::kGap;
  }
  result.step = step;
  return result;
}

}  // namespace fieldline::fusion
