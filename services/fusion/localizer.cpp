#include "services/fusion/localizer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>

#include "services/fusion/localizer_internal.hpp"

namespace fieldline::fusion {
namespace {

using localizer_internal::near;
using perception::LocalizationStatus;

TimedChannelLimits deadReckoningLimits() {
  TimedChannelLimits limits;
  // Ten seconds of 50 Hz odometry: hypotheses are moved over at most that, and the continuity
  // reference of a loss (which may predate an unconfirmed commit) as well.
  limits.capacity = 512;
  limits.future_tolerance_us = 500'000;
  return limits;
}

}  // namespace

FilterParams Localizer::withGyro(FilterParams params, const robot::RobotParams& robot) {
  params.noise.gyro_bias_walk = robot.gyro.present ? robot.gyro.bias_walk : 0.0;
  return params;
}

Localizer::Localizer(const robot::RobotParams& robot, LocalizerParams params,
                     MatcherFunctions matcher)
    : robot_(robot),
      params_(params),
      matcher_(std::move(matcher)),
      odometry_(robot, params.odometry),
      currents_(robot, params.current_contact),
      filter_(withGyro(params.filter, robot)),
      dead_reckoning_(deadReckoningLimits()) {}

bool Localizer::addOdometry(const OdometrySample& sample, Utime now) {
  last_odometry_arrival_ = std::max(last_odometry_arrival_, now);
  const CurrentContactDetector::Result contact = currents_.add(sample);
  if (!contact.rejection.empty()) count(contact.rejection);
  if (contact.contact) {
    ++counters_.current_contacts;
    const Rejection c = filter_.addContact(*contact.contact, now);
    if (c != Rejection::kNone) count(std::string("current_") + toString(c));
  }
  const OdometryLayer::Result r = odometry_.update(sample);
  if (r.rejection != OdometryRejection::kNone) count(toString(r.rejection));
  if (r.gyro_rejection) count(r.gyro_rejection);
  if (r.step && r.step->gyro) ++counters_.gyro_steps;
  if (!r.step) {
    if (r.rejection != OdometryRejection::kNone && r.rejection != OdometryRejection::kDuplicate) {
      // The dead-reckoning reference restarts: older hypotheses cannot be moved across the break.
      dead_reckoning_.clear();
    }
    if (dead_reckoning_.empty()) dead_reckoning_.insert(sample.utime, odometry_pose_, now);
    if (pending_resume_) anchorResume();
    if (!waiting_.empty()) processWaiting(now);
    return false;
  }
  const OdometryStep& step = *r.step;
  const geometry::Movement m = robot::arcMovement(step.integrated);
  const geometry::Pose2 before{odometry_pose_.x(), odometry_pose_.y(), odometry_pose_.z()};
  const geometry::Pose2 after = geometry::applyMovement(before, m);
  odometry_pose_ = {after.x, after.y, odometry_pose_.z() + m.dphi};
  if (step.has_velocity) last_velocity_ = step.integrated / step.duration();
  dead_reckoning_.insert(step.t_end, odometry_pose_, now);
  if (pending_resume_) anchorResume();

  const Rejection rejection = filter_.addOdometry(step, now);
  if (!waiting_.empty()) processWaiting(now);
  if (rejection != Rejection::kNone) {
    count(std::string("odometry_") + toString(rejection));
    return false;
  }
  return true;
}

std::optional<geometry::Movement> Localizer::motionBetween(Utime t1, Utime t2) const {
  if (dead_reckoning_.empty()) return {};
  auto poseAt = [&](Utime t) -> std::optional<Eigen::Vector3d> {
    if (t >= dead_reckoning_.newest().utime) return dead_reckoning_.newest().value;
    if (t < dead_reckoning_.oldest().utime) return {};
    return dead_reckoning_.at(t);
  };
  const auto a = poseAt(t1);
  const auto b = poseAt(t2);
  if (!a || !b) return {};
  const geometry::Vec2 d = geometry::rotate((*b - *a).head<2>(), -a->z());
  return geometry::Movement{d.x(), d.y(), b->z() - a->z()};
}

Eigen::Matrix3d Localizer::floored(const Eigen::Matrix3d& c) const {
  Eigen::Matrix3d out = c;
  out(0, 0) += params_.correction_floor_m * params_.correction_floor_m;
  out(1, 1) += params_.correction_floor_m * params_.correction_floor_m;
  out(2, 2) += params_.correction_floor_rad * params_.correction_floor_rad;
  return out;
}

Eigen::Matrix3d Localizer::correctionCovariance(const PoseCorrection& c,
                                                const Eigen::Vector3d& velocity) const {
  Eigen::Matrix3d out = floored(params_.correction_inflation * c.covariance);
  // A frame stamped off by dt sees the pose the robot had dt away: (vx, vy, omega) * dt.
  out += stampSpread(velocity, params_.correction_stamp_sigma_s);
  const double cost = std::max(0.0, c.cost);
  const double s_m = params_.correction_cost_gain * cost;
  const double s_rad = params_.correction_cost_gain_rad * cost;
  out(0, 0) += s_m * s_m;
  out(1, 1) += s_m * s_m;
  out(2, 2) += s_rad * s_rad;
  return out;
}

Eigen::Matrix3d stampSpread(const Eigen::Vector3d& velocity, double sigma_s) {
  return sigma_s * sigma_s * velocity * velocity.transpose();
}

Eigen::Matrix3d Localizer::reportedCovariance(const EkfState& s) const {
  Eigen::Matrix3d c = s.p.topLeftCorner<3, 3>();
  const double fm = params_.state_floor_m * params_.state_floor_m;
  const double fr = params_.state_floor_rad * params_.state_floor_rad;
  c += stampSpread(s.groundVelocity(), params_.stamp_sigma_s);
  c(0, 0) += fm;
  c(1, 1) += fm;
  c(2, 2) += fr;
  return c;
}

template <typename MakeWaiting>
bool Localizer::admitFrame(Utime utime, Utime now, const char* from_future,
                           MakeWaiting make_waiting) {
  if (utime > now + params_.filter.future_tolerance_us) {
    count(from_future);
    return false;
  }
  if (!mustWait(utime, now)) return true;
  WaitingFrame w = make_waiting();
  w.utime = utime;
  waiting_.push_back(std::move(w));
  ++counters_.frames_waited;
  processWaiting(now);
  return false;
}

void Localizer::addLines(std::span<const perception::LinePoint> points, Utime utime, Utime now) {
  last_lines_arrival_ = std::max(last_lines_arrival_, now);
  const bool now_ready = admitFrame(utime, now, "lines_from_future", [&] {
    WaitingFrame w;
    w.points.assign(points.begin(), points.end());
    return w;
  });
  if (now_ready) processLines(points, utime, now);
}

void Localizer::processWaiting(Utime now) {
  std::stable_sort(waiting_.begin(), waiting_.end(),
                   [](const WaitingFrame& a, const WaitingFrame& b) { return a.utime < b.utime; });
  // Ready: odometry reached the frame, or it waited its time, or odometry is silent (then the
  // filter predicts with the held velocity rather than never fusing a frame again).
  const Utime reached = newestOdometry();
  const bool silent = odometrySilent(now);
  std::size_t done = 0;
  while (done < waiting_.size() && (waiting_[done].utime <= reached || silent ||
                                    now - waiting_[done].utime > params_.max_wait_us)) {
    WaitingFrame& w = waiting_[done];
    if (w.features) {
      processFeatures(*w.features, w.utime, now);
    } else {
      processLines(w.points, w.utime, now);
    }
    ++done;
  }
  waiting_.erase(waiting_.begin(), waiting_.begin() + static_cast<std::ptrdiff_t>(done));
  // Only what is still waiting is trimmed.
  while (waiting_.size() > params_.max_waiting_frames) {
    count(waiting_.front().features ? "features_odometry_stalled" : "lines_odometry_stalled");
    waiting_.erase(waiting_.begin());
  }
}

void Localizer::processLines(std::span<const perception::LinePoint> points, Utime utime,
                             Utime now) {
  if (mode_ == LocalizationStatus::kTracking) {
    trackLines(points, utime, now);
  } else {
    searchLines(points, utime);
  }
}

void Localizer::addFeatures(const perception::FieldFeatures& features, Utime utime, Utime now) {
  if (features.hypotheses.empty()) return;
  const bool now_ready = admitFrame(utime, now, "features_from_future", [&] {
    WaitingFrame w;
    w.features = features;
    return w;
  });
  if (now_ready) processFeatures(features, utime, now);
}

void Localizer::addObstacles(const perception::ObstacleSightings& sightings, Utime now) {
  const ContactModel& contact = params_.filter.contact;
  bool touching = false;
  for (const perception::ObstacleSighting& o : sightings.obstacles) {
    if (!std::isfinite(o.distance) || o.distance < 0.0) {
      count("obstacles_not_finite");
      return;
    }
    touching = touching || o.distance < contact.distance_m;
  }
  if (!touching) return;
  ++counters_.contact_frames;
  const Rejection r = filter_.addContact(sightings.utime, now);
  if (r != Rejection::kNone) count(std::string("obstacles_") + toString(r));
}

std::optional<EkfState> Localizer::stateAt(Utime t) const {
  if (!filter_.initialized()) return {};
  return filter_.stateAt(t);
}

double Localizer::lastCorrectionM() const {
  return filter_.initialized() ? filter_.current().last_correction_m : 0.0;
}

double Localizer::lastCorrectionRad() const {
  return filter_.initialized() ? filter_.current().last_correction_rad : 0.0;
}

perception::RobotEstimate Localizer::estimate(Utime now) const {
  perception::RobotEstimate e;
  e.status = mode_;
  if (filter_.initialized()) {
    const EkfState& s = filter_.current();
    e.utime = s.utime;
    e.pose = s.pose();
    const Eigen::Vector3d v = s.groundVelocity();
    e.vx = v.x();
    e.vy = v.y();
    e.omega = v.z();
    e.covariance = reportedCovariance(s);
    e.since_vision_us = s.last_correction_utime > 0 ? s.utime - s.last_correction_utime : 0;
    e.twin_ambiguous = ambiguous_ && mode_ == LocalizationStatus::kTracking;
  } else {
    e.utime = dead_reckoning_.empty() ? 0 : dead_reckoning_.newest().utime;
    if (!hypotheses_.empty()) {
      // The best guess so far, carried to the newest odometry.
      const Hypothesis& h = hypotheses_.front();
      e.pose = h.pose;
      if (const auto motion = motionBetween(h.utime, e.utime))
        e.pose = geometry::applyMovement(h.pose, *motion);
    }
    e.covariance = Eigen::Vector3d(100.0, 100.0, 10.0).asDiagonal();
  }
  e.status = reportedStatus(e.covariance, now);
  return e;
}

perception::LocalizationStatus Localizer::reportedStatus(const Eigen::Matrix3d& covariance,
                                                         Utime now) const {
  if (mode_ != LocalizationStatus::kTracking) return mode_;
  if (reset_unconfirmed_ > 0) return LocalizationStatus::kSearching;
  // After a restart the own-half prior may have picked the twin (resumeFrom).
  if (restarted_ && twin_undecided_) return LocalizationStatus::kSearching;
  if (last_lines_arrival_ == 0 || now - last_lines_arrival_ > params_.vision_timeout_us)
    return LocalizationStatus::kOdometryOnly;
  if (params_.tracking_max_sigma_m > 0.0) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(covariance.topLeftCorner<2, 2>());
    const double largest = es.eigenvalues()[1];
    // A NaN covariance promises nothing either.
    if (!(largest <= params_.tracking_max_sigma_m * params_.tracking_max_sigma_m))
      return LocalizationStatus::kOdometryOnly;
  }
  return LocalizationStatus::kTracking;
}

}  // namespace fieldline::fusion
