// The constants every stage of mirror calibration uses, in one place (the library is a unity
// build: file-local copies in each .cpp would clash).
#pragma once

#include <limits>
#include <numbers>

namespace fieldline::calibration {

inline constexpr double kPi = std::numbers::pi;
// "No value" for radii and residuals that a ray or sector did not give.
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace fieldline::calibration
