// The localizer's twin resolution: which of a pose and its point-symmetric twin to commit to
// (continuity, the start prior), the commit, and the team's votes on the twin.
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

}  // namespace

Localizer::Hypothesis Localizer::resolveTwin(const Hypothesis& h, const Hypothesis* twin) {
  // The twin fits the lines as well by symmetry, whether or not it is among the hypotheses.
  Hypothesis mirrored = twin ? *twin : h;
  if (!twin) mirrored.pose = symmetricTwin(h.pose);
  const auto motion =
      reference_ ? motionBetween(reference_->utime, h.utime) : std::optional<geometry::Movement>{};
  if (reference_ && !motion) {
    // The reference cannot be carried here (the dead reckoning broke or is too short): nothing
    // resolves the twin.
    ambiguous_ = twin_undecided_ = true;
    ++counters_.ambiguous_commits;
    return h;
  }
  if (reference_) {
    // Continuity: the pose before the loss, carried by odometry to now.
    const geometry::Pose2 ref = geometry::applyMovement(reference_->pose, *motion);
    const double dh = localizer_internal::poseDistance(h.pose, ref);
    const double dt = localizer_internal::poseDistance(mirrored.pose, ref);
    // The reference is only as good as the filter was at the loss.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(
        reference_->covariance.topLeftCorner<2, 2>());
    const double sigma =
        es.info() == Eigen::Success ? std::sqrt(std::max(0.0, es.eigenvalues()[1])) : 1e9;
    const double margin =
        std::max({params_.twin_margin_m, params_.twin_margin_sigmas * sigma, reference_->unseen_m});
    twin_undecided_ = std::abs(dh - dt) < margin;
    // A reference that was itself ambiguous passes that on (a resumed start-up pose: as before
    // the restart, only the start-up prior and continuity since tell the twins apart).
    ambiguous_ = twin_undecided_ || reference_->twin_ambiguous;
    if (ambiguous_) ++counters_.ambiguous_commits;
    return dh <= dt ? h : mirrored;
  }
  ambiguous_ = twin_undecided_ = true;
  ++counters_.ambiguous_commits;
  if (params_.start_prior == StartPrior::kNone) return h;
  // Robots enter the field in their own half (x < 0), facing the opponent goal when on the line.
  const auto own = [](const geometry::Pose2& p) {
    return p.x < -0.25 || (p.x <= 0.25 && std::abs(p.phi) < std::numbers::pi / 2);
  };
  return own(h.pose) || !own(mirrored.pose) ? h : mirrored;
}

void Localizer::resumeFrom(const geometry::Pose2& pose, const Eigen::Matrix3d& covariance,
                           Utime saved_utime, bool twin_ambiguous) {
  Hypothesis saved;
  saved.utime = saved_utime;
  saved.pose = pose;
  saved.covariance = covariance;
  saved.twin_ambiguous = twin_ambiguous;
  pending_resume_ = saved;
  restarted_ = true;
  ++counters_.resumed;
  if (!dead_reckoning_.empty()) anchorResume();
}

void Localizer::anchorResume() {
  Hypothesis ref = *pending_resume_;
  pending_resume_.reset();
  // A pose is known already (the saved one came too late to matter): nothing to resume.
  if (filter_.initialized() || reference_) return;
  // From the first odometry on, dead reckoning carries the saved pose; before it, the robot moved
  // unseen for the restart's gap, as far as a push could carry it (SlipModel).
  const Utime anchor = dead_reckoning_.newest().utime;
  const SlipModel& slip = filter_.params().slip;
  const double gap_s = static_cast<double>(std::max<Utime>(0, anchor - ref.utime)) * 1e-6;
  ref.unseen_m = slip.max_speed > 0.0 ? slip.base_m + slip.max_speed * gap_s : 1e9;
  ref.utime = anchor;
  reference_ = ref;
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
      ambiguous_ = twin_undecided_ = false;
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
    ambiguous_ = twin_undecided_ = true;
    ++counters_.twin_doubted_by_team;
    return;
  }
  // The whole history moves, so frames still in flight replay onto the twin's past.
  filter_.mirrorThroughCentre();
  // The team's answer supersedes the pose before the loss as the next loss's reference.
  reference_.reset();
  ambiguous_ = twin_undecided_ = false;
  gated_in_row_ = 0;
  gated_offset_.reset();
  weighted_heading_offset_.reset();
  ++counters_.twin_flips_by_team;
}

}  // namespace fieldline::fusion
