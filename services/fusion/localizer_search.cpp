// The localizer searching: hypotheses from the global search over the whole field, around the
// last pose and in heading, kept until one of them (or its twin) is confirmed.
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

// The hypothesis a matcher's correction of one frame (at `utime`) gives (a template only because
// Localizer::Hypothesis is private).
template <typename Hypothesis>
Hypothesis hypothesisFrom(const PoseCorrection& c, Utime utime) {
  Hypothesis h;
  h.utime = utime;
  h.pose = c.pose;
  h.covariance = c.covariance;
  h.cost_sum = c.cost;
  h.frames = 1;
  return h;
}

}  // namespace

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
      if (c.valid) addHypothesis(hypothesisFrom<Hypothesis>(c, utime));
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
    if (c.valid) refined.push_back(hypothesisFrom<Hypothesis>(c, utime));
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
    addHypothesis(hypothesisFrom<Hypothesis>(c, utime));
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

}  // namespace fieldline::fusion
