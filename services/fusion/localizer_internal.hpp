// What the localizer's files (localizer.cpp: the frame queue and the estimate; localizer_tracking,
// _search, _twin, _features) share besides the class.
#pragma once

#include <cmath>

#include "common/geometry/geometry.hpp"

namespace fieldline::fusion::localizer_internal {

// True if `a` and `b` are within `d_m` of each other and their headings within `d_rad`.
inline bool near(const geometry::Pose2& a, const geometry::Pose2& b, double d_m, double d_rad) {
  return std::hypot(a.x - b.x, a.y - b.y) <= d_m &&
         std::abs(geometry::angleDiff(a.phi, b.phi)) <= d_rad;
}

// Two search hypotheses this close are one place (the better-fitting is kept): within the
// coarse grid's half step (search_step_m 0.5) and about a heading step (24 per turn: 0.26 rad).
inline constexpr double kSamePlaceM = 0.4;
inline constexpr double kSamePlaceRad = 0.3;
// At a commit, a hypothesis this close to the best (or to its twin) is that minimum found again
// from another seed, not a rival place that fits about as well.
inline constexpr double kSameMinimumM = 0.5;
inline constexpr double kSameMinimumRad = 0.35;
// A pose distance for choosing between a pose and its twin: mostly position (a robot carried
// off is often turned as well, rarely moved half a field), a radian counting as 0.2 m, as in
// twin_margin_m.
inline constexpr double kMetresPerRadian = 0.2;
inline double poseDistance(const geometry::Pose2& a, const geometry::Pose2& b) {
  return std::hypot(a.x - b.x, a.y - b.y) +
         kMetresPerRadian * std::abs(geometry::angleDiff(a.phi, b.phi));
}
// A feature hypothesis with a position sigma above this is too vague to contradict the estimate.
inline constexpr double kContradictMaxSigmaM = 0.3;

}  // namespace fieldline::fusion::localizer_internal
