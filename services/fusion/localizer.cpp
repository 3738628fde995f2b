#include "services/fusion/localizer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>

namespace fieldline::fusion {
namespace {

using perception::LocalizationStatus;

bool near(const geometry::Pose2& a, const geometry::Pose2& b, double d_m, double d_rad) {
  return std::hypot(a.x - b.x, a.y - b.y) <= d_m &&
         std::abs(geometry::angleDiff(a.phi, b.phi)) <= d_rad;
}

// Two search hypotheses this close are one place (the better-fitting is kept): within the
// coarse grid's half step (search_step_m 0.5) and about a heading step (24 per turn: 0.26 rad).
constexpr double kSamePlaceM = 0.4;
constexpr double kSamePlaceRad = 0.3;
// At a commit, a hypothesis this close to the best (or to its twin) is that minimum found again
// from another seed, not a rival place that fits about as well.
constexpr double kSameMinimumM = 0.5;
constexpr double kSameMinimumRad = 0.35;
// A pose distance for choosing between a pose and its twin: mostly position (a robot carried
// off is often turned as well, rarely moved half a field), a radian counting as 0.2 m, as in
// twin_margin_m.
constexpr double kMetresPerRadian = 0.2;
double poseDistance(const geometry::Pose2& a, const geometry::Pose2& b) {
  return std::hypot(a.x - b.x, a.y - b.y) +
         kMetresPerRadian * std::abs(geometry::angleDiff(a.phi, b.phi));
}
// A feature hypothesis with a position sigma above this is too vague to contradict the estimate.
constexpr double kContradictMaxSigmaM = 0.3;

TimedChannelLimits deadReckoningLimits() {
  TimedChannelLimits limits;
  // Ten seconds of 50 Hz odometry: hypotheses are moved over at most that, and the continuity
  // reference of a loss (which may predate an unconfirmed commit) as well.
  limits.capacity = 512;
  limits.future_tolerance_us = 500'000;
  return limits;
}

// What a frame's position disagreement `d` with the estimate says, given the frame's covariance
// `r` and the estimate's `p` (squared Mahalanobis distances against `chi2`). When the frame's
// sigmas differ by less than `ratio` it pins every direction down; otherwise it pins down only
// the direction across its long axis, and a disagreement along that axis alone is what an
// aliased match (sliding along the line it sees) looks like.
struct Disagreement {
  bool pinned = false;
  bool along_long_axis = false;
};

Disagreement classifyDisagreement(const Eigen::Vector2d& d, const Eigen::Matrix2d& r,
                                  const Eigen::Matrix2d& p, double ratio, double chi2) {
  Disagreement out;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(r);
  if (es.info() != Eigen::Success) return out;
  const Eigen::Vector2d ev = es.eigenvalues();  // ascending
  if (!(ev[0] > 0.0)) return out;
  const Eigen::Matrix2d s = r + p;
  if (ev[1] < ratio * ratio * ev[0]) {
    out.pinned = d.dot(s.ldlt().solve(d)) > chi2;
    return out;
  }
  const Eigen::Vector2d tight = es.eigenvectors().col(0);
  const Eigen::Vector2d loose = es.eigenvectors().col(1);
  const double across = tight.dot(d);
  const double along = loose.dot(d);
  out.pinned = across * across > chi2 * tight.dot(s * tight);
  out.along_long_axis = !out.pinned && along * along > chi2 * loose.dot(s * loose);
  return out;
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

void Localizer::addLines(std::span<const perception::LinePoint> points, Utime utime, Utime now) {
  last_lines_arrival_ = std::max(last_lines_arrival_, now);
  if (utime > now + params_.filter.future_tolerance_us) {
    count("lines_from_future");
    return;
  }
  if (mustWait(utime, now)) {
    WaitingFrame w;
    w.utime = utime;
    w.points.assign(points.begin(), points.end());
    waiting_.push_back(std::move(w));
    ++counters_.frames_waited;
    processWaiting(now);
    return;
  }
  processLines(points, utime, now);
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

void Localizer::trackLines(std::span<const perception::LinePoint> points, Utime utime, Utime now) {
  const auto guess = filter_.stateAt(utime);
  if (!guess) {
    count("lines_too_old");
    return;
  }
  PoseCorrection c = matcher_.correct(points, guess->pose());
  const double cost_at_estimate = matcher_.cost(points, guess->pose());
  last_cost_ = cost_at_estimate;
  // Twisted in contact beyond what the matcher reaches from the estimate: search the heading.
  const bool contact = filter_.inContact(utime);
  bool twist_found = false;
  // With the gyro's heading the robot cannot have turned unseen: no heading search (unless
  // asked for).
  const bool may_search = !guess->gyro || params_.twist_search_with_gyro;
  if (params_.contact_search_steps > 0 && may_search && (contact || params_.twist_search_always) &&
      !(c.valid && c.cost <= params_.accept_cost_m) &&
      points.size() >= params_.contact_search_min_points) {
    if (const auto found = searchHeadings(points, guess->pose(), params_.contact_search_steps)) {
      c = *found;
      twist_found = true;
      ++counters_.twist_searches;
    }
  }
  bool good = false;
  if (c.valid && c.cost <= params_.accept_cost_m) {
    PoseMeasurement z{utime, c.pose, correctionCovariance(c, guess->groundVelocity())};
    const Eigen::Vector3d offset(c.pose.x - guess->pose().x, c.pose.y - guess->pose().y,
                                 geometry::normalizeAngle(c.pose.phi - guess->pose().phi));
    const bool confirmed =
        gated_offset_ &&
        (offset.head<2>() - gated_offset_->head<2>()).norm() <= params_.slip_confirm_m &&
        std::abs(geometry::normalizeAngle(offset[2] - (*gated_offset_)[2])) <=
            params_.slip_confirm_rad;
    // A single frame reveals a slip when the lines pin its disagreement down, or when it twists
    // the heading without sliding along the one line it sees (an aliased match); otherwise the
    // next frame must confirm it.
    Disagreement seen;
    if (params_.slip_pinned_ratio > 0.0) {
      seen = classifyDisagreement(offset.head<2>(), z.covariance.topLeftCorner<2, 2>(),
                                  guess->p.topLeftCorner<2, 2>(), params_.slip_pinned_ratio,
                                  params_.slip_pinned_chi2);
    }
    const bool pinned = seen.pinned;
    const bool twisted =
        std::abs(offset[2]) >= params_.slip_single_frame_rad && !seen.along_long_axis;
    // In contact (the robot's camera saw an obstacle at its body) a push or twist is expected:
    // the frame is taken at once.
    z.may_reveal_slip = confirmed || twisted || pinned || contact || twist_found;
    // The gyro's heading is trusted over a single frame's; two frames that agree on a heading
    // disagreement are taken.
    const bool heading_confirmed =
        weighted_heading_offset_ &&
        std::abs(geometry::normalizeAngle(offset[2] - *weighted_heading_offset_)) <=
            params_.heading_confirm_rad;
    z.robust_heading = !heading_confirmed;
    const auto r = filter_.addPose(MeasurementSource::kLines, z, now);
    if (heading_confirmed && r.rejection == Rejection::kNone) ++counters_.headings_confirmed;
    if (r.update.heading_weighted_down) {
      ++counters_.headings_weighted_down;
      weighted_heading_offset_ = offset[2];
    } else {
      weighted_heading_offset_.reset();
    }
    if (r.rejection == Rejection::kNone) {
      ++counters_.corrections;
      if (r.update.slip) {
        ++counters_.slips;
        if (pinned && !confirmed && !twisted) ++counters_.pinned_slips;
        if (contact && !pinned && !confirmed && !twisted) ++counters_.contact_slips;
      }
      good = true;
      ++good_since_commit_;
      if (reset_unconfirmed_ > 0) --reset_unconfirmed_;
      gated_in_row_ = 0;
      gated_offset_.reset();
    } else {
      count(std::string("lines_") + toString(r.rejection));
      if (r.rejection == Rejection::kGated) {
        gated_offset_ = offset;
      } else {
        gated_offset_.reset();
      }
      // Frames that match the field well but disagree with an overconfident filter (a slip the
      // odometry did not see): after a few in a row, the frames are right.
      const geometry::Pose2 twin = symmetricTwin(guess->pose());
      if (r.rejection == Rejection::kGated && gated_in_row_ + 1 >= params_.gated_frames_reset &&
          poseDistance(c.pose, twin) < poseDistance(c.pose, guess->pose())) {
        // The frames say the robot stands nearer the estimate's symmetric twin: that is no slip
        // a reset may follow, the symmetry cannot tell it from the estimate. Search instead
        // (continuity decides there).
        ++counters_.twin_resets_refused;
        gated_in_row_ = 0;
        gated_offset_.reset();
        becomeLost(utime);
        searchLines(points, utime);
        return;
      }
      if (r.rejection == Rejection::kGated && ++gated_in_row_ >= params_.gated_frames_reset) {
        gated_in_row_ = 0;
        gated_offset_.reset();
        ++counters_.resets;
        EkfState s = *guess;
        s.utime = utime;
        s.x.head<3>() << c.pose.x, c.pose.y, c.pose.phi;
        s.p.topLeftCorner<3, 3>() = correctionCovariance(c, guess->groundVelocity());
        // The pose restarts from the frame; velocity and gyro bias keep what was learnt.
        s.p.topRightCorner<3, kStateSize - 3>().setZero();
        s.p.bottomLeftCorner<kStateSize - 3, 3>().setZero();
        s.last_correction_utime = utime;
        filter_.initialize(s);
        restart_utime_ = utime;
        same_run_ = twin_run_ = 0;
        reset_unconfirmed_ = params_.reset_confirm_frames;
        good = true;
      }
    }
  } else {
    count(c.valid ? "lines_poor_match" : "lines_too_few_points");
    gated_offset_.reset();
    weighted_heading_offset_.reset();
  }
  // Only frames with enough points can contradict: an empty view says nothing. A frame with
  // plenty of points that gives no valid correction from the estimate (too few of them near any
  // line, seen from there: the heading is far off) contradicts it as well.
  const bool many_points = points.size() >= params_.contradict_min_points;
  const bool contradicts =
      (c.valid || many_points) && !good && cost_at_estimate > params_.lost_cost_m;
  bad_frames_ = contradicts ? bad_frames_ + 1 : (good ? 0 : bad_frames_);
  if (bad_frames_ >= params_.lost_frames ||
      (contradicts && contradictions_ >= 2 && bad_frames_ >= 1)) {
    becomeLost(utime);
    searchLines(points, utime);
  }
}

void Localizer::becomeLost(Utime utime) {
  ++counters_.lost;
  mode_ = LocalizationStatus::kSearching;
  bad_frames_ = 0;
  contradictions_ = 0;
  hypotheses_.clear();
  weighted_heading_offset_.reset();
  // A commit that was never confirmed by line frames is no reference: the one before it stays
  // (carried by odometry when used). The very first commit has nothing before it.
  if (good_since_commit_ >= params_.trust_frames || !reference_) {
    reference_.reset();
    if (const auto s = filter_.stateAt(utime)) {
      Hypothesis ref;
      ref.utime = utime;
      ref.pose = s->pose();
      ref.covariance = s->p.topLeftCorner<3, 3>();
      const double reach = filter_.params().slip.reachBy(*s, utime);
      if (reach < SlipModel::kNoBound) ref.unseen_m = reach;
      reference_ = ref;
    }
  }
}

void Localizer::addHypothesis(const Hypothesis& h) {
  for (Hypothesis& other : hypotheses_) {
    if (near(other.pose, h.pose, kSamePlaceM, kSamePlaceRad)) {
      if (h.frames > 0 && h.meanCost() < other.meanCost()) other = h;
      return;
    }
  }
  hypotheses_.push_back(h);
}

void Localizer::coarseSearch(std::span<const perception::LinePoint> points, Utime utime) {
  ++counters_.searches;
  if (matcher_.global_search) {
    for (const PoseCorrection& c : matcher_.global_search(points)) {
      if (!c.valid) continue;
      Hypothesis h;
      h.utime = utime;
      h.pose = c.pose;
      h.covariance = c.covariance;
      h.cost_sum = c.cost;
      h.frames = 1;
      addHypothesis(h);
    }
    return;
  }
  // A spread subset of the points keeps the search cheap.
  std::vector<perception::LinePoint> subset;
  const std::size_t stride =
      std::max<std::size_t>(1, points.size() / static_cast<std::size_t>(params_.search_points));
  for (std::size_t i = 0; i < points.size(); i += stride)
    subset.push_back(points[i]);
  struct Scored {
    double cost;
    geometry::Pose2 pose;
  };
  std::vector<Scored> scored;
  const double step = params_.search_step_m;
  for (double x = -params_.search_half_length_m; x <= params_.search_half_length_m; x += step) {
    for (double y = -params_.search_half_width_m; y <= params_.search_half_width_m; y += step) {
      for (int k = 0; k < params_.search_headings; ++k) {
        const geometry::Pose2 p{
            x, y, geometry::normalizeAngle(2.0 * std::numbers::pi * k / params_.search_headings)};
        scored.push_back({matcher_.cost(subset, p), p});
      }
    }
  }
  std::sort(scored.begin(), scored.end(),
            [](const Scored& a, const Scored& b) { return a.cost < b.cost; });
  // The best distinct cells, refined by the matcher on all points; the best refined ones stay.
  std::vector<geometry::Pose2> picked;
  std::vector<Hypothesis> refined;
  const std::size_t candidates = 3 * params_.max_hypotheses;
  for (const Scored& s : scored) {
    if (picked.size() >= candidates) break;
    bool distinct = true;
    for (const auto& p : picked)
      if (near(p, s.pose, 1.2 * step, 2.5 * std::numbers::pi / params_.search_headings))
        distinct = false;
    if (!distinct) continue;
    picked.push_back(s.pose);
    const PoseCorrection c = matcher_.correct(points, s.pose);
    if (!c.valid) continue;
    Hypothesis h;
    h.utime = utime;
    h.pose = c.pose;
    h.covariance = c.covariance;
    h.cost_sum = c.cost;
    h.frames = 1;
    refined.push_back(h);
  }
  std::sort(refined.begin(), refined.end(),
            [](const Hypothesis& a, const Hypothesis& b) { return a.meanCost() < b.meanCost(); });
  for (std::size_t i = 0; i < refined.size() && i < params_.max_hypotheses; ++i)
    addHypothesis(refined[i]);
}

void Localizer::localSearch(std::span<const perception::LinePoint> points, Utime utime) {
  if (!reference_ || params_.local_search_s <= 0.0 ||
      static_cast<double>(utime - reference_->utime) * 1e-6 > params_.local_search_s) {
    return;
  }
  geometry::Pose2 ref = reference_->pose;
  const auto motion = motionBetween(reference_->utime, utime);
  if (!motion) return;
  ref = geometry::applyMovement(ref, *motion);
  for (int k = -params_.local_search_steps; k <= params_.local_search_steps; ++k) {
    const geometry::Pose2 guess{
        ref.x, ref.y, geometry::normalizeAngle(ref.phi + k * params_.local_search_step_rad)};
    const PoseCorrection c = matcher_.correct(points, guess);
    if (!c.valid || c.cost > params_.accept_cost_m) continue;
    Hypothesis h;
    h.utime = utime;
    h.pose = c.pose;
    h.covariance = c.covariance;
    h.cost_sum = c.cost;
    h.frames = 1;
    addHypothesis(h);
  }
}

std::optional<PoseCorrection> Localizer::searchHeadings(
    std::span<const perception::LinePoint> points, const geometry::Pose2& guess, int steps) const {
  std::optional<PoseCorrection> best;
  for (int k = -steps; k <= steps; ++k) {
    if (k == 0) continue;
    const geometry::Pose2 turned{
        guess.x, guess.y, geometry::normalizeAngle(guess.phi + k * params_.local_search_step_rad)};
    const PoseCorrection c = matcher_.correct(points, turned);
    if (!c.valid || c.cost > params_.accept_cost_m) continue;
    if (!best || c.cost < best->cost) best = c;
  }
  return best;
}

void Localizer::searchLines(std::span<const perception::LinePoint> points, Utime utime) {
  if (mode_ == LocalizationStatus::kUnknown) mode_ = LocalizationStatus::kSearching;
  // Test what we have on this frame.
  for (Hypothesis& h : hypotheses_) {
    if (h.utime >= utime) continue;  // found on this frame already
    const auto motion = motionBetween(h.utime, utime);
    if (!motion) {
      h.frames = -1;  // cannot be carried to this frame: dropped below
      continue;
    }
    const geometry::Pose2 moved = geometry::applyMovement(h.pose, *motion);
    const PoseCorrection c = matcher_.correct(points, moved);
    h.utime = utime;
    if (c.valid) {
      h.pose = c.pose;
      h.covariance = c.covariance;
      h.cost_sum += c.cost;
    } else {
      h.pose = moved;
      h.cost_sum += matcher_.cost(points, moved);
    }
    ++h.frames;
  }
  // Tested twice and still a poor fit: not this place.
  std::erase_if(hypotheses_, [&](const Hypothesis& h) {
    return h.frames < 0 || (h.frames >= 2 && h.meanCost() > params_.accept_cost_m) ||
           (h.frames > 0 && h.meanCost() > params_.lost_cost_m);
  });
  const bool enough_points = static_cast<int>(points.size()) >= 10;
  if (enough_points) localSearch(points, utime);
  const bool any_good = std::any_of(hypotheses_.begin(), hypotheses_.end(), [&](const auto& h) {
    return h.frames > 0 && h.meanCost() <= params_.accept_cost_m;
  });
  if (!any_good && enough_points) coarseSearch(points, utime);
  if (hypotheses_.empty()) return;

  std::sort(hypotheses_.begin(), hypotheses_.end(),
            [](const Hypothesis& a, const Hypothesis& b) { return a.meanCost() < b.meanCost(); });
  if (hypotheses_.size() > params_.max_hypotheses) hypotheses_.resize(params_.max_hypotheses);

  const Hypothesis& best = hypotheses_.front();
  if (best.frames < params_.commit_frames || best.meanCost() > params_.accept_cost_m) return;
  const Hypothesis* twin = nullptr;
  const geometry::Pose2 twin_pose = symmetricTwin(best.pose);
  for (std::size_t i = 1; i < hypotheses_.size(); ++i) {
    const Hypothesis& h = hypotheses_[i];
    if (near(h.pose, best.pose, kSameMinimumM, kSameMinimumRad)) continue;
    if (near(h.pose, twin_pose, kSameMinimumM, kSameMinimumRad)) {
      if (!twin) twin = &h;
      continue;
    }
    // Another place fits about as well: wait for more frames.
    if (h.frames > 0 && h.meanCost() < best.meanCost() + params_.commit_margin_m) return;
  }
  commit(resolveTwin(best, twin));
}

Localizer::Hypothesis Localizer::resolveTwin(const Hypothesis& h, const Hypothesis* twin) {
  // The twin fits the lines as well by symmetry, whether or not it is among the hypotheses.
  Hypothesis mirrored = twin ? *twin : h;
  if (!twin) mirrored.pose = symmetricTwin(h.pose);
  const auto motion =
      reference_ ? motionBetween(reference_->utime, h.utime) : std::optional<geometry::Movement>{};
  if (reference_ && !motion) {
    // The reference cannot be carried here (the dead reckoning broke or is too short): nothing
    // resolves the twin.
    ambiguous_ = true;
    ++counters_.ambiguous_commits;
    return h;
  }
  if (reference_) {
    // Continuity: the pose before the loss, carried by odometry to now.
    const geometry::Pose2 ref = geometry::applyMovement(reference_->pose, *motion);
    const double dh = poseDistance(h.pose, ref);
    const double dt = poseDistance(mirrored.pose, ref);
    // The reference is only as good as the filter was at the loss.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(
        reference_->covariance.topLeftCorner<2, 2>());
    const double sigma =
        es.info() == Eigen::Success ? std::sqrt(std::max(0.0, es.eigenvalues()[1])) : 1e9;
    const double margin =
        std::max({params_.twin_margin_m, params_.twin_margin_sigmas * sigma, reference_->unseen_m});
    ambiguous_ = std::abs(dh - dt) < margin;
    if (ambiguous_) ++counters_.ambiguous_commits;
    return dh <= dt ? h : mirrored;
  }
  ambiguous_ = true;
  ++counters_.ambiguous_commits;
  if (params_.start_prior == StartPrior::kNone) return h;
  // Robots enter the field in their own half (x < 0), facing the opponent goal when on the line.
  const auto own = [](const geometry::Pose2& p) {
    return p.x < -0.25 || (p.x <= 0.25 && std::abs(p.phi) < std::numbers::pi / 2);
  };
  return own(h.pose) || !own(mirrored.pose) ? h : mirrored;
}

void Localizer::commit(const Hypothesis& h) {
  ++counters_.commits;
  EkfState s;
  s.utime = h.utime;
  const geometry::Vec2 v = geometry::rotate(last_velocity_.head<2>(), h.pose.phi);
  s.x.head<6>() << h.pose.x, h.pose.y, h.pose.phi, v.x(), v.y(), last_velocity_.z();
  s.p = StateMatrix::Zero();
  s.p.topLeftCorner<3, 3>() = floored(h.covariance);
  s.p(0, 0) = std::max(s.p(0, 0), params_.commit_sigma_m * params_.commit_sigma_m);
  s.p(1, 1) = std::max(s.p(1, 1), params_.commit_sigma_m * params_.commit_sigma_m);
  s.p(2, 2) = std::max(s.p(2, 2), params_.commit_sigma_rad * params_.commit_sigma_rad);
  s.p.block<3, 3>(3, 3) = Eigen::Vector3d(0.25, 0.25, 0.5).asDiagonal();
  // The gyro bias learnt before a loss stays (the gyro did not change); the first commit starts
  // from the robot file's spread of a start's bias.
  if (filter_.initialized()) {
    s.x[kGyroBias] = filter_.current().x[kGyroBias];
    s.p(kGyroBias, kGyroBias) = filter_.current().p(kGyroBias, kGyroBias);
  } else {
    s.p(kGyroBias, kGyroBias) = robot_.gyro.bias_sigma * robot_.gyro.bias_sigma;
  }
  s.last_correction_utime = h.utime;
  filter_.initialize(s);
  restart_utime_ = h.utime;
  mode_ = LocalizationStatus::kTracking;
  hypotheses_.clear();
  bad_frames_ = 0;
  contradictions_ = 0;
  // Gated frames of the track before the loss say nothing about this pose (a reset from them
  // right after the commit jumped away from it).
  gated_in_row_ = 0;
  gated_offset_.reset();
  good_since_commit_ = 0;
  reset_unconfirmed_ = 0;
  same_run_ = twin_run_ = 0;
}

void Localizer::addTwinVote(TwinVote vote, Utime utime) {
  if (params_.twin_vote_run <= 0 || vote == TwinVote::kNone) return;
  if (mode_ != LocalizationStatus::kTracking || !filter_.initialized()) {
    same_run_ = twin_run_ = 0;
    return;
  }
  // Votes far apart are no run.
  if (utime - last_vote_utime_ > params_.twin_vote_gap_us) same_run_ = twin_run_ = 0;
  last_vote_utime_ = utime;
  if (vote == TwinVote::kSame) {
    twin_run_ = 0;
    if (ambiguous_ && ++same_run_ >= params_.twin_vote_run) {
      ambiguous_ = false;
      same_run_ = 0;
      ++counters_.twin_confirmed_by_team;
    }
    return;
  }
  same_run_ = 0;
  if (++twin_run_ < params_.twin_vote_run) return;
  twin_run_ = 0;
  if (!ambiguous_) {
    // Continuity had called this pose certain: a first run only makes it ambiguous, a second one
    // moves it (with one vote per team picture, six pictures at least: 0.5 s at 10 Hz).
    ambiguous_ = true;
    ++counters_.twin_doubted_by_team;
    return;
  }
  // The whole history moves, so frames still in flight replay onto the twin's past.
  filter_.mirrorThroughCentre();
  // The team's answer supersedes the pose before the loss as the next loss's reference.
  reference_.reset();
  ambiguous_ = false;
  gated_in_row_ = 0;
  gated_offset_.reset();
  weighted_heading_offset_.reset();
  ++counters_.twin_flips_by_team;
}

void Localizer::addFeatures(const perception::FieldFeatures& features, Utime utime, Utime now) {
  if (features.hypotheses.empty()) return;
  if (utime > now + params_.filter.future_tolerance_us) {
    count("features_from_future");
    return;
  }
  if (mustWait(utime, now)) {
    WaitingFrame w;
    w.utime = utime;
    w.features = features;
    waiting_.push_back(std::move(w));
    ++counters_.frames_waited;
    processWaiting(now);
    return;
  }
  processFeatures(features, utime, now);
}

void Localizer::processFeatures(const perception::FieldFeatures& features, Utime utime, Utime now) {
  if (mode_ != LocalizationStatus::kTracking) {
    for (const perception::PoseHypothesis& ph : features.hypotheses) {
      if (!geometry::isFinite(ph.pose) || !(ph.sigma_xy > 0) || !(ph.sigma_phi > 0)) {
        count("features_not_finite");
        continue;
      }
      Hypothesis h;
      h.utime = utime;
      h.pose = ph.pose;
      h.covariance = Eigen::Vector3d(ph.sigma_xy * ph.sigma_xy, ph.sigma_xy * ph.sigma_xy,
                                     ph.sigma_phi * ph.sigma_phi)
                         .asDiagonal();
      addHypothesis(h);
      Hypothesis t = h;
      t.pose = symmetricTwin(h.pose);
      addHypothesis(t);
    }
    return;
  }
  // The features of the frame the filter restarted from (a commit or a reset from its line
  // points, which arrive first), or of an earlier one: the restart already holds what they say.
  // Not bad input; only beyond that is the frame too old.
  const char* const too_old =
      utime <= restart_utime_ && utime + params_.filter.window_us >= restart_utime_
          ? "features_before_restart"
          : "features_too_old";
  const auto est = filter_.stateAt(utime);
  if (!est) {
    count(too_old);
    return;
  }
  const geometry::Pose2 e = est->pose();
  // One measurement per frame (the filter keeps one per utime and channel, gated or not: a second
  // hypothesis of the same frame was refused as a duplicate, and counted as bad input): among
  // those within the feature gate, the likeliest given the estimate: the smallest negative log
  // likelihood of its innovation (Mahalanobis distance squared plus ln det of the innovation's
  // covariance, the estimate's plus the hypothesis's), so a vague hypothesis does not win over a
  // precise one merely by being vague.
  const Eigen::Matrix3d estimate_covariance = est->p.topLeftCorner<3, 3>();
  const perception::PoseHypothesis* likeliest = nullptr;
  double likeliest_cost = 0.0;
  bool all_far = true;
  for (const perception::PoseHypothesis& ph : features.hypotheses) {
    if (!geometry::isFinite(ph.pose) || !(ph.sigma_xy > 0) || !(ph.sigma_phi > 0)) {
      count("features_not_finite");
      continue;
    }
    if (near(ph.pose, e, params_.feature_gate_m, params_.feature_gate_rad)) {
      const Eigen::Vector3d innovation(ph.pose.x - e.x, ph.pose.y - e.y,
                                       geometry::angleDiff(ph.pose.phi, e.phi));
      Eigen::Matrix3d s = estimate_covariance;
      s.diagonal() += Eigen::Vector3d(ph.sigma_xy * ph.sigma_xy, ph.sigma_xy * ph.sigma_xy,
                                      ph.sigma_phi * ph.sigma_phi);
      const Eigen::LDLT<Eigen::Matrix3d> ldlt(s);
      const double cost =
          innovation.dot(ldlt.solve(innovation)) + ldlt.vectorD().array().log().sum();
      if (!likeliest || cost < likeliest_cost) {
        likeliest = &ph;
        likeliest_cost = cost;
      }
    }
    const double d = std::min(std::hypot(ph.pose.x - e.x, ph.pose.y - e.y),
                              std::hypot(-ph.pose.x - e.x, -ph.pose.y - e.y));
    if (d <= params_.contradict_m || ph.sigma_xy > kContradictMaxSigmaM) all_far = false;
  }
  bool fused = false;
  if (likeliest) {
    PoseMeasurement z;
    z.utime = utime;
    z.pose = likeliest->pose;
    z.covariance = Eigen::Vector3d(likeliest->sigma_xy * likeliest->sigma_xy,
                                   likeliest->sigma_xy * likeliest->sigma_xy,
                                   likeliest->sigma_phi * likeliest->sigma_phi)
                       .asDiagonal();
    const auto r = filter_.addPose(MeasurementSource::kFeatures, z, now);
    if (r.rejection == Rejection::kNone) {
      ++counters_.feature_updates;
      fused = true;
    } else if (r.rejection == Rejection::kTooOld) {
      count(too_old);
    } else {
      count(std::string("features_") + toString(r.rejection));
    }
  }
  contradictions_ = (!fused && all_far) ? contradictions_ + 1 : 0;
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
