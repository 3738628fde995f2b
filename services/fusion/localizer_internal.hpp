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

}  // namespace fieldline::fusion::localizer_internal
