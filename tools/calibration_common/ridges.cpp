#include "tools/calibration_common/ridges.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>

namespace fieldline::calibration {

using camera::Vec2;

namespace {

const double kS2 = std::sqrt(0.5);
// The four directions a pixel is crossed in: rows, columns, both diagonals.
const std::array<Vec2, 4> kDirs = {Vec2(1, 0), Vec2(0, 1), Vec2(kS2, kS2), Vec2(kS2, -kS2)};

// Light smoothing (binomial 1-2-1 in both directions) against sensor noise.
GreyImage smoothed(const GreyImage& image) {
  const int w = image.width;
  const int h = image.height;
  GreyImage smooth{w, h, image.pixels};
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
  return smooth;
}

// The direction (of kDirs) across which a pixel is most a ridge, the flank distance and the
// brighter flank's luma there; dir -1 when no direction shows it brighter than its flanks.
struct Crossing {
  double contrast = 0.0;
  int dir = -1;
  double hw = 0.0, flank = 0.0;
};

Crossing strongestCrossing(const GreyImage& smooth, const Vec2& p, double centre,
                           const RidgeParams& params) {
  Crossing best;
  for (int d = 0; d < 4; ++d) {
    // Contrast at each flank distance; the smallest one that reaches 80 % of the largest
    // (a wide line's centre is not brighter than points inside it).
    std::array<double, 8> c{};
    std::array<double, 8> f{};
    double most = -1e9;
    const std::size_t n = std::min<std::size_t>(params.half_widths.size(), 8);
    for (std::size_t k = 0; k < n; ++k) {
      const Vec2 a = p - params.half_widths[k] * kDirs[static_cast<std::size_t>(d)];
      const Vec2 b = p + params.half_widths[k] * kDirs[static_cast<std::size_t>(d)];
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
    if (most <= best.contrast) continue;
    for (std::size_t k = 0; k < n; ++k) {
      if (c[k] >= 0.8 * most) {
        best.contrast = c[k];
        best.hw = params.half_widths[k];
        best.flank = f[k];
        best.dir = d;
        break;
      }
    }
  }
  return best;
}

// The ridge through pixel p across the crossing's direction: the profile's samples above half
// height around the centre, their weighted centre. nullopt when the pixel is not the one
// nearest to that centre (each crossing once) or the profile is a bright area, not a ridge.
std::optional<Ridge> ridgeAcross(const GreyImage& smooth, const Vec2& p, double centre,
                                 const Crossing& best, double maxHw) {
  const Vec2 n = kDirs[static_cast<std::size_t>(best.dir)];
  const double half = best.flank + 0.5 * best.contrast;
  constexpr double kStep = 0.25;
  const int reach = static_cast<int>(std::ceil((best.hw + 1.0) / kStep));
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
  if (!(sw > 0.0)) return std::nullopt;
  const double offset = st / sw;
  // Each crossing once: the pixel nearest to the centre along the direction keeps it.
  const double cell = best.dir < 2 ? 0.5 : 0.5 * kS2;
  if (std::abs(offset) > cell + 1e-9) return std::nullopt;
  if (hi - lo > 2.0 * maxHw + 2.0) return std::nullopt;  // a bright area, not a ridge
  Ridge ridge;
  ridge.pixel = p + offset * n;
  ridge.normal = n;
  ridge.half_width = best.hw;
  ridge.width = hi - lo + kStep;
  ridge.peak = centre;
  ridge.flank = best.flank;
  return ridge;
}

}  // namespace

std::vector<Ridge> findRidges(const GreyImage& image, const RidgeParams& params) {
  if (image.width < 8 || image.height < 8 ||
      image.pixels.size() != static_cast<std::size_t>(image.width) * image.height) {
    throw std::invalid_argument("ridges: the image is too small or inconsistent");
  }
  if (params.half_widths.empty() || !(params.min_contrast > 0.0) || !(params.min_ratio >= 1.0)) {
    throw std::invalid_argument("ridges: half widths, contrast > 0 and ratio >= 1 expected");
  }
  const int w = image.width;
  const int h = image.height;
  const GreyImage smooth = smoothed(image);
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
      const Crossing best = strongestCrossing(smooth, p, centre, params);
      if (best.dir < 0 || best.contrast < params.min_contrast ||
          centre < params.min_ratio * best.flank) {
        continue;
      }
      if (const std::optional<Ridge> ridge = ridgeAcross(smooth, p, centre, best, maxHw)) {
        out.push_back(*ridge);
      }
    }
  }
  return out;
}

}  // namespace fieldline::calibration
