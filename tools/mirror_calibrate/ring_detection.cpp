// Mirror calibration from rings, stages 1-3: ridges along rays from the mirror centre, rings
// traced outward from them, and which ring is which distance.
#include "tools/mirror_calibrate/mirror_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>
#include <Eigen/Dense>

#include "common/geometry/fitting.hpp"
#include "tools/mirror_calibrate/numbers.hpp"

namespace fieldline::calibration {

namespace {

// Image radius along image direction `dir` from `from` to the circle (centre, radius).
double circleAlongRay(const Vec2& from, const Vec2& dir, const Vec2& centre, double radius) {
  const Vec2 f = from - centre;
  const double b = f.dot(dir);
  const double disc = b * b - (f.squaredNorm() - radius * radius);
  return disc < 0.0 ? kNaN : -b + std::sqrt(disc);
}

}  // namespace

// --- stage 1: ridges along rays ---

std::vector<RingPeak> findRingPeaks(const GreyImage& image, const Vec2& centre,
                                    const RingSearchParams& params) {
  if (params.rays < 8 || !(params.step > 0.0) || !(params.window > params.step) ||
      !(params.max_radius > params.min_radius) || params.min_radius < 0.0) {
    throw std::invalid_argument("ring search: bad parameters");
  }
  std::vector<RingPeak> peaks;
  const int w = static_cast<int>(std::lround(params.window / params.step));
  const double r0 = std::max(0.0, params.min_radius - params.window);
  const int n = static_cast<int>((params.max_radius + params.window - r0) / params.step) + 1;
  std::vector<double> raw(static_cast<std::size_t>(n));
  std::vector<double> p(static_cast<std::size_t>(n));
  for (int ray = 0; ray < params.rays; ++ray) {
    const double a = 2.0 * kPi * ray / params.rays;
    const Vec2 dir(std::cos(a), std::sin(a));
    int len = 0;
    for (; len < n; ++len) {
      const Vec2 q = centre + (r0 + len * params.step) * dir;
      const double s = image.sample(q.x(), q.y());
      if (!std::isfinite(s)) break;
      raw[static_cast<std::size_t>(len)] = s;
    }
    // Light smoothing (binomial over one pixel) against sensor noise.
    for (int i = 0; i < len; ++i) {
      const auto at = [&](int k) {
        return raw[static_cast<std::size_t>(std::clamp(k, 0, len - 1))];
      };
      p[static_cast<std::size_t>(i)] =
          (at(i - 2) + 4 * at(i - 1) + 6 * at(i) + 4 * at(i + 1) + at(i + 2)) / 16.0;
    }
    int lastEnd = -1;
    for (int i = w; i + w < len; ++i) {
      const double r = r0 + i * params.step;
      if (r < params.min_radius || r > params.max_radius) continue;
      const double v = p[static_cast<std::size_t>(i)];
      // A local maximum (the first sample of a plateau).
      if (!(v > p[static_cast<std::size_t>(i - 1)])) continue;
      int j = i;
      while (j + 1 < len && p[static_cast<std::size_t>(j + 1)] == v)
        ++j;
      if (j + 1 >= len || !(p[static_cast<std::size_t>(j + 1)] < v)) continue;
      const int mid = (i + j) / 2;
      double left = std::numeric_limits<double>::infinity();
      double right = left;
      for (int k = mid - w; k < mid; ++k)
        left = std::min(left, p[static_cast<std::size_t>(std::max(k, 0))]);
      for (int k = mid + 1; k <= mid + w; ++k)
        right = std::min(right, p[static_cast<std::size_t>(std::min(k, len - 1))]);
      const double base = std::max(left, right);
      const double contrast = v - base;
      if (contrast < params.min_contrast) continue;
      // The ridge: samples above half height around the maximum; its brightness-weighted centre.
      const double half = base + 0.5 * contrast;
      int lo = i;
      int hi = j;
      while (lo - 1 >= 0 && p[static_cast<std::size_t>(lo - 1)] > half)
        --lo;
      while (hi + 1 < len && p[static_cast<std::size_t>(hi + 1)] > half)
        ++hi;
      if (lo <= lastEnd) continue;  // the same ridge as the previous maximum
      lastEnd = hi;
      double sw = 0.0;
      double sr = 0.0;
      for (int k = lo; k <= hi; ++k) {
        const double wk = p[static_cast<std::size_t>(k)] - half;
        sw += wk;
        sr += wk * (r0 + k * params.step);
      }
      const double radius = sw > 0.0 ? sr / sw : r;
      peaks.push_back({ray, radius, contrast, centre + radius * dir});
      i = j;
    }
  }
  return peaks;
}

// --- stage 2: rings, traced outward ---

std::vector<TracedRing> traceRings(const std::vector<RingPeak>& peaks, int rays, const Vec2& centre,
                                   double min_share, double gap) {
  std::vector<std::vector<const RingPeak*>> byRay(static_cast<std::size_t>(rays));
  for (const RingPeak& p : peaks) {
    if (p.ray >= 0 && p.ray < rays) byRay[static_cast<std::size_t>(p.ray)].push_back(&p);
  }
  for (auto& list : byRay) {
    std::sort(list.begin(), list.end(),
              [](const RingPeak* a, const RingPeak* b) { return a->radius < b->radius; });
  }
  std::vector<TracedRing> rings;
  // Per ray: the radius beyond which the next ring is looked for.
  std::vector<double> floorRadius(static_cast<std::size_t>(rays), 0.0);
  for (int guard = 0; guard < 64; ++guard) {
    std::vector<Vec2> pts;
    std::vector<int> rayOf;
    for (int ray = 0; ray < rays; ++ray) {
      for (const RingPeak* p : byRay[static_cast<std::size_t>(ray)]) {
        if (p->radius > floorRadius[static_cast<std::size_t>(ray)]) {
          pts.push_back(p->pixel);
          rayOf.push_back(ray);
          break;
        }
      }
    }
    if (static_cast<double>(pts.size()) < min_share * rays) break;
    TracedRing ring;
    std::vector<bool> keep;
    if (!geometry::fitCircleRobust(pts, ring.centre, ring.radius, keep, 2.0)) break;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      if (keep[i]) ring.pixels.push_back(pts[i]);
    }
    if (static_cast<double>(ring.pixels.size()) < min_share * rays) break;
    rings.push_back(ring);
    // Next ring: beyond this one's circle (or its point on the ray) plus the gap.
    for (int ray = 0; ray < rays; ++ray) {
      const double a = 2.0 * kPi * ray / rays;
      const double onCircle =
          circleAlongRay(centre, Vec2(std::cos(a), std::sin(a)), ring.centre, ring.radius);
      floorRadius[static_cast<std::size_t>(ray)] =
          std::max(floorRadius[static_cast<std::size_t>(ray)],
                   std::isfinite(onCircle) ? onCircle + gap : 1e9);
    }
  }
  return rings;
}

// --- stage 3: which ring is which distance ---

namespace {

// RMS relative misfit of d = a r + b r^2 + c r^3 through the pairs.
double cubicMisfit(const std::vector<double>& r, const std::vector<double>& d) {
  const auto n = static_cast<Eigen::Index>(r.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = r[static_cast<std::size_t>(i)];
    const double y = d[static_cast<std::size_t>(i)];
    // Weighted by 1/d: relative misfit.
    a(i, 0) = x / y;
    a(i, 1) = x * x / y;
    a(i, 2) = x * x * x / y;
    b(i) = 1.0;
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(b);
  return std::sqrt((a * c - b).squaredNorm() / static_cast<double>(n));
}

}  // namespace

RingMatch matchRings(const std::vector<double>& radii, const std::vector<double>& distances) {
  const int k = static_cast<int>(radii.size());
  const int m = static_cast<int>(distances.size());
  const int count = std::min(k, m);
  if (count < 4) {
    throw std::invalid_argument(fmt::format(
        "ring matching: {} rings found and {} distances given; at least 4 of each are needed", k,
        m));
  }
  RingMatch best;
  best.misfit = std::numeric_limits<double>::infinity();
  // Slide the shorter list along the longer one.
  for (int shift = 0; shift <= std::abs(k - m); ++shift) {
    const int fr = k > m ? shift : 0;
    const int fd = k > m ? 0 : shift;
    std::vector<double> r(radii.begin() + fr, radii.begin() + fr + count);
    std::vector<double> d(distances.begin() + fd, distances.begin() + fd + count);
    const double misfit = cubicMisfit(r, d);
    if (misfit < best.misfit) best = {fr, fd, count, misfit};
  }
  return best;
}

}  // namespace fieldline::calibration
