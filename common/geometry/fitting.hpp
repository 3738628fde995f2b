// Small robust statistics and fits shared by the calibration tools and the evaluations: the
// median, and a circle through points (Kasa's algebraic fit, and a version that drops outliers).
#pragma once

#include <vector>

#include "common/geometry/geometry.hpp"

namespace fieldline::geometry {

// The median of `values` (the upper middle one of an even count); NaN for none.
double median(std::vector<double> values);

// Kasa's circle fit: the centre and radius of the circle closest (algebraically) to `points`.
// False for fewer than 5 points, or when the fit gives no positive radius or no finite centre.
bool fitCircle(const std::vector<Vec2>& points, Vec2& centre, double& radius);

// A circle through `points` (Kasa fit) that drops points more than `gate` off it, in three rounds
// (the first gate at least 3 times the median residual); keep[i] says which were kept. False for
// fewer than 5 points or a degenerate fit.
bool fitCircleRobust(const std::vector<Vec2>& points, Vec2& centre, double& radius,
                     std::vector<bool>& keep, double gate);

}  // namespace fieldline::geometry
