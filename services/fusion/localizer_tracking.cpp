// The localizer tracking: each frame's line points matched from the estimate, a slip accepted
// or confirmed, a reset after gated frames, the loss of the track.
#include "services/fusion/localizer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>

#include "services/fusion/localizer_internal.hpp"

namespace fieldline::fusion {
namespace {

using namespace localizer_internal;
using perception::LocalizationStatus;

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

std::optional<PoseCorrection> Localizer::searchTwist(std::span<const perception::LinePoint> points,
                                                     const EkfState& guess, const PoseCorrection& c,
                                                     bool contact) const {
  // With the gyro's heading the robot cannot have turned unseen: no heading search (unless
  // asked for).
  const bool may_search = !guess.gyro || params_.twist_search_with_gyro;
  if (params_.contact_search_steps > 0 && may_search && (contact || params_.twist_search_always) &&
      !(c.valid && c.cost <= params_.accept_cost_m) &&
      points.size() >= params_.contact_search_min_points) {
    return searchHeadings(points, guess.pose(), params_.contact_search_steps);
  }
  return std::nullopt;
}

Localizer::SlipEvidence Localizer::slipEvidence(const Eigen::Vector3d& offset,
                                                const PoseMeasurement& z,
                                                const EkfState& guess) const {
  SlipEvidence e;
  e.confirmed = gated_offset_ &&
                (offset.head<2>() - gated_offset_->head<2>()).norm() <= params_.slip_confirm_m &&
                std::abs(geometry::normalizeAngle(offset[2] - (*gated_offset_)[2])) <=
                    params_.slip_confirm_rad;
  // A single frame reveals a slip when the lines pin its disagreement down, or when it twists
  // the heading without sliding along the one line it sees (an aliased match); otherwise the
  // next frame must confirm it.
  Disagreement seen;
  if (params_.slip_pinned_ratio > 0.0) {
    seen = classifyDisagreement(offset.head<2>(), z.covariance.topLeftCorner<2, 2>(),
                                guess.p.topLeftCorner<2, 2>(), params_.slip_pinned_ratio,
                                params_.slip_pinned_chi2);
  }
  e.pinned = seen.pinned;
  e.twisted = std::abs(offset[2]) >= params_.slip_single_frame_rad && !seen.along_long_axis;
  return e;
}

void Localizer::resetToFrame(const PoseCorrection& c, const EkfState& guess, Utime utime) {
  gated_in_row_ = 0;
  gated_offset_.reset();
  ++counters_.resets;
  EkfState s = guess;
  s.utime = utime;
  s.x.head<3>() << c.pose.x, c.pose.y, c.pose.phi;
  s.p.topLeftCorner<3, 3>() = correctionCovariance(c, guess.groundVelocity());
  // The pose restarts from the frame; velocity and gyro bias keep what was learnt.
  s.p.topRightCorner<3, kStateSize - 3>().setZero();
  s.p.bottomLeftCorner<kStateSize - 3, 3>().setZero();
  s.last_correction_utime = utime;
  filter_.initialize(s);
  restart_utime_ = utime;
  same_run_ = twin_run_ = 0;
  reset_unconfirmed_ = params_.reset_confirm_frames;
}

Localizer::RejectedLines Localizer::onRejectedLines(Rejection rejection,
                                                    const Eigen::Vector3d& offset,
                                                    const PoseCorrection& c, const EkfState& guess,
                                                    std::span<const perception::LinePoint> points,
                                                    Utime utime) {
  count(std::string("lines_") + toString(rejection));
  if (rejection == Rejection::kGated) {
    gated_offset_ = offset;
  } else {
    gated_offset_.reset();
  }
  // Frames that match the field well but disagree with an overconfident filter (a slip the
  // odometry did not see): after a few in a row, the frames are right.
  const geometry::Pose2 twin = symmetricTwin(guess.pose());
  if (rejection == Rejection::kGated && gated_in_row_ + 1 >= params_.gated_frames_reset &&
      poseDistance(c.pose, twin) < poseDistance(c.pose, guess.pose())) {
    // The frames say the robot stands nearer the estimate's symmetric twin: that is no slip
    // a reset may follow, the symmetry cannot tell it from the estimate. Search instead
    // (continuity decides there).
    ++counters_.twin_resets_refused;
    gated_in_row_ = 0;
    gated_offset_.reset();
    becomeLost(utime);
    searchLines(points, utime);
    return RejectedLines::kSearched;
  }
  if (rejection == Rejection::kGated && ++gated_in_row_ >= params_.gated_frames_reset) {
    resetToFrame(c, guess, utime);
    return RejectedLines::kReset;
  }
  return RejectedLines::kKept;
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
  const bool contact = filter_.inContact(utime);
  bool twist_found = false;
  if (const auto found = searchTwist(points, *guess, c, contact)) {
    c = *found;
    twist_found = true;
    ++counters_.twist_searches;
  }
  bool good = false;
  if (c.valid && c.cost <= params_.accept_cost_m) {
    PoseMeasurement z{utime, c.pose, correctionCovariance(c, guess->groundVelocity())};
    const Eigen::Vector3d offset(c.pose.x - guess->pose().x, c.pose.y - guess->pose().y,
                                 geometry::normalizeAngle(c.pose.phi - guess->pose().phi));
    const SlipEvidence evidence = slipEvidence(offset, z, *guess);
    const bool confirmed = evidence.confirmed;
    const bool pinned = evidence.pinned;
    const bool twisted = evidence.twisted;
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
      const RejectedLines next = onRejectedLines(r.rejection, offset, c, *guess, points, utime);
      if (next == RejectedLines::kSearched) return;
      good = next == RejectedLines::kReset;
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

}  // namespace fieldline::fusion
