#include "services/fusion/time_shift.hpp"

#include <algorithm>
#include <cmath>

#include "common/geometry/geometry.hpp"

namespace fieldline::fusion {
namespace {

// Linear interpolation in a time-sorted series; empty outside it.
std::optional<double> rateAt(const std::vector<RateSample>& s, Utime t) {
  if (s.empty() || t < s.front().utime || t > s.back().utime) return {};
  auto it = std::lower_bound(s.begin(), s.end(), t,
                             [](const RateSample& r, Utime v) { return r.utime < v; });
  if (it->utime == t) return it->rate;
  const RateSample& b = *it;
  const RateSample& a = *std::prev(it);
  const double w = static_cast<double>(t - a.utime) / static_cast<double>(b.utime - a.utime);
  return a.rate + (b.rate - a.rate) * w;
}

}  // namespace

std::vector<RateSample> ratesFromBearings(const std::vector<BallBearing>& sightings,
                                          Utime max_gap_us, double min_range_m) {
  std::vector<RateSample> out;
  for (std::size_t i = 1; i < sightings.size(); ++i) {
    const BallBearing& a = sightings[i - 1];
    const BallBearing& b = sightings[i];
    const Utime dt = b.utime - a.utime;
    if (dt <= 0 || dt > max_gap_us) continue;
    if (std::hypot(a.x, a.y) < min_range_m || std::hypot(b.x, b.y) < min_range_m) continue;
    const double turn = geometry::angleDiff(std::atan2(b.y, b.x), std::atan2(a.y, a.x));
    out.push_back({a.utime + dt / 2, -turn / (static_cast<double>(dt) * 1e-6)});
  }
  return out;
}

std::optional<TimeShift> estimateTimeShift(const std::vector<RateSample>& odometry,
                                           const std::vector<RateSample>& vision,
                                           Utime max_shift_us, Utime step_us) {
  if (odometry.size() < 10 || vision.size() < 10 || step_us <= 0) return {};
  std::optional<TimeShift> best;
  // Compare on a 5 ms grid over odometry's span.
  const Utime grid = 5'000;
  for (Utime shift = -max_shift_us; shift <= max_shift_us; shift += step_us) {
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    int n = 0;
    for (Utime t = odometry.front().utime; t <= odometry.back().utime; t += grid) {
      const auto a = rateAt(odometry, t);
      const auto b = rateAt(vision, t + shift);
      if (!a || !b) continue;
      sa += *a;
      sb += *b;
      saa += *a * *a;
      sbb += *b * *b;
      sab += *a * *b;
      ++n;
    }
    if (n < 20) continue;
    const double cov = sab - sa * sb / n;
    const double va = saa - sa * sa / n;
    const double vb = sbb - sb * sb / n;
    if (va <= 1e-12 || vb <= 1e-12) continue;
    const double r = cov / std::sqrt(va * vb);
    if (!best || r > best->correlation) best = TimeShift{shift, r, n};
  }
  return best;
}

}  // namespace fieldline::fusion
