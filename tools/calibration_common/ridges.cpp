#include "tools/calibration_common/ridges.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace fieldline::calibration {

using camera::Vec2;

std::vector<Ridge> findRidges(const GreyImage& image, const RidgeParams& params) {
  if (image.width < 8 || image.height < 8 ||
      image.pixels.size() != static_cast<std::size_t>(image.width) * image.height) {
    throw std::invalid_argument("ridges: the image is too small or inconsistent");
  }
  if (params.half_widths.empty() || !(params.min_contrast > 0.0) || !(params.min_ratio >= 1.0)) {
    throw std::invalid_argument("ridges: half widths, contrast > 0 and ratio >= 1 expected");
  }
  // Light smoothing (binomial 1-2-1 in both directions) against sensor noise.
  const int w = image.width;
  const int h = image.height;
  GreyImage smooth{w, h, image.pixels};
  {
    std::vector<int> tmp(image.pixels.size());
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const int l = image.at(std::max(u - 1, 0), v), c = image.at(u, v),
                  r = image.at(std::min(u + 1, w - 1), v);
        tmp[static_cast<std::size_t>(v) * w + u] = l + 2 * c + r;
      }
    }
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const int t = tmp[static_cast<std::size_t>(std::max(v - 1, 0)) * w + u];
        const int c = tmp[static_cast<std::size_t>(v) * w + u];
        const int b = tmp[static_cast<std::size_t>(std::min(v + 1, h - 1)) * w + u];
        smooth.pixels[static_cast<std::size_t>(v) * w + u] =
            static_cast<std::uint8_t>((t + 2 * c + b + 8) / 16);
      }
    }
  }
  const double s2 = std::sqrt(0.5);
  const std::array<Vec2, 4> dirs = {Vec2(1, 0), Vec2(0, 1), Vec2(s2, s2), Vec2(s2, -s2)};
  const double maxHw = *std::max_element(params.half_widths.begin(), params.half_widths.end());
  std::vector<Ridge> out;
  const int u0 = std::max(1, static_cast<int>(std::floor(params.centre.x() - params.max_radius)));
  const int u1 =
      std::min(w - 2, static_cast<int>(std::ceil(params.centre.x() + params.max_radius)));
  const int v0 = std::max(1, static_cast<int>(std::floor(params.centre.y() - params.max_radius)));
  const int v1 =
      std::min(h - 2, static_cast<int>(std::ceil(params.centre.y() + params.max_radius)));
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const Vec2 p(u, v);
      const double r = (p - params.centre).norm();
      if (r < params.min_radius || r > params.max_radius) continue;
      const double centre = smooth.at(u, v);
      double bestContrast = 0.0;
      int bestDir = -1;
      double bestHw = 0.0, bestFlank = 0.0;
      for (int d = 0; d < 4; ++d) {
        // Contrast at each flank distance; the smallest one that reaches 80 % of the largest
        // (a wide line's centre is not brighter than points inside it).
        std::array<double, 8> c{};
        std::array<double, 8> f{};
        double most = -1e9;
        const std::size_t n = std::min<std::size_t>(params.half_widths.size(), 8);
        for (std::size_t k = 0; k < n; ++k) {
          const Vec2 a = p - params.half_widths[k] * dirs[static_cast<std::size_t>(d)];
          const Vec2 b = p + params.half_widths[k] * dirs[static_cast<std::size_t>(d)];
          const double sa = smooth.sample(a.x(), a.y());
          const double sb = smooth.sample(b.x(), b.y());
          if (!std::isfinite(sa) || !std::isfinite(sb)) {
            c[k] = -1e9;
            continue;
          }
          f[k] = std::max(sa, sb);
          c[k] = centre - f[k];
          most = std::max(most, c[k]);
        }
        if (most <= bestContrast) continue;
        for (std::size_t k = 0; k < n; ++k) {
          if (c[k] >= 0.8 * most) {
            bestContrast = c[k];
            bestHw = params.half_widths[k];
            bestFlank = f[k];
            bestDir = d;
            break;
          }
        }
      }
      if (bestDir < 0 || bestContrast < params.min_contrast ||
          centre < params.min_ratio * bestFlank) {
        continue;
      }
      // The profile across: samples above half height around the centre, their weighted centre.
      const Vec2 n = dirs[static_cast<std::size_t>(bestDir)];
      const double half = bestFlank + 0.5 * bestContrast;
      constexpr double kStep = 0.25;
      const int reach = static_cast<int>(std::ceil((bestHw + 1.0) / kStep));
      double sw = 0.0, st = 0.0;
      double lo = 0.0, hi = 0.0;
      for (int side : {-1, 1}) {
        for (int k = side < 0 ? 1 : 0; k <= reach; ++k) {
          const double t = side * k * kStep;
          const Vec2 q = p + t * n;
          const double s = smooth.sample(q.x(), q.y());
          if (!std::isfinite(s) || s <= half) break;
          sw += s - half;
          st += (s - half) * t;
          (side < 0 ? lo : hi) = t;
        }
      }
      if (!(sw > 0.0)) continue;
      const double offset = st / sw;
      // Each crossing once: the pixel nearest to the centre along the direction keeps it.
      const double cell = bestDir < 2 ? 0.5 : 0.5 * s2;
      if (std::abs(offset) > cell + 1e-9) continue;
      if (hi - lo > 2.0 * maxHw + 2.0) continue;  // a bright area, not a ridge
      Ridge ridge;
      ridge.pixel = p + offset * n;
      ridge.normal = n;
      ridge.half_width = bestHw;
      ridge.width = hi - lo + kStep;
      ridge.peak = centre;
      ridge.flank = bestFlank;
      out.push_back(ridge);
    }
  }
  return out;
}

}  // namespace fieldline::calibration
