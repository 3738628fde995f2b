// Pixel coordinates shared by the detectors' sources (internal to region_tracking).
#pragma once

#include <limits>

namespace fieldline::region_tracking::detail {

inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Contour points are cell corners; pixel centres sit at integer coordinates, so the corner
// between pixels u-1 and u is at u - 0.5.
inline constexpr float kCornerToPixel = -0.5f;

// Nearest pixel coordinate; below -0.5 anything negative (outside the frame either way).
// Cheaper than std::lround, which is a library call.
inline int nearestPixel(float coordinate) {
  const float shifted = coordinate + 0.5f;
  return shifted < 0.0f ? -1 : static_cast<int>(shifted);
}

}  // namespace fieldline::region_tracking::detail
