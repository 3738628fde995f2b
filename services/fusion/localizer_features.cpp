// The localizer's feature hypotheses: kept while searching, the likeliest within the gate fused
// while tracking.
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

}  // namespace

void Localizer::keepFeatureHypotheses(const perception::FieldFeatures& features, Utime utime) {
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
}

void Localizer::processFeatures(const perception::FieldFeatures& features, Utime utime, Utime now) {
  if (mode_ != LocalizationStatus::kTracking) {
    keepFeatureHypotheses(features, utime);
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

}  // namespace fieldline::fusion
