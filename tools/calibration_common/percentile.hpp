// Percentiles and medians of samples as the calibration tools take them: the nearest rank, no
// interpolation (a figure is always one of the samples).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace fieldline::calibration {

// The value at percentile p (0..100, clamped) of `sorted` (ascending, not empty): the nearest
// rank, p 0 the smallest, 100 the largest, 50 the upper median.
template <typename T>
T percentileOfSorted(const std::vector<T>& sorted, double p) {
  const double pos = std::clamp(p / 100.0, 0.0, 1.0) * static_cast<double>(sorted.size() - 1);
  return sorted[static_cast<std::size_t>(std::lround(pos))];
}

// percentileOfSorted of `v` once sorted; NaN when `v` is empty.
double percentileOf(std::vector<double> v, double p);

// The upper median of `v` (element size/2 once sorted: percentileOf(v, 50), found without
// sorting all of it); NaN when `v` is empty.
double upperMedian(std::vector<double> v);

}  // namespace fieldline::calibration
