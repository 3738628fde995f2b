#include "tools/calibration_common/floor_colour.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tools/calibration_common/percentile.hpp"

namespace fieldline::calibration {

bool FloorColour::chromaMatches(const camera::Yuv& c) const {
  return std::hypot(c.u - u, c.v - v) <= chroma_reach;
}

std::vector<camera::Yuv> yuvPlane(const camera::FrameView& f) {
  std::vector<camera::Yuv> out(static_cast<std::size_t>(f.width) * f.height);
  for (int v = 0; v < f.height; ++v) {
    for (int u = 0; u < f.width; ++u)
      out[static_cast<std::size_t>(v) * f.width + u] = camera::readYuv(f, u, v);
  }
  return out;
}

FloorColour findFloorColour(const std::vector<std::vector<camera::Yuv>>& planes,
                            const std::vector<std::uint8_t>& mask, int stride) {
  FloorColour out;
  const std::size_t n = mask.size();
  const auto step = static_cast<std::size_t>(std::max(1, stride));
  std::vector<double> hist(256 * 256, 0.0);
  for (const auto& plane : planes) {
    for (std::size_t i = 0; i < n && i < plane.size(); i += step) {
      if (!mask[i]) continue;
      hist[static_cast<std::size_t>(plane[i].u) * 256 + plane[i].v] += 1.0;
      ++out.pixels;
    }
  }
  if (out.pixels < 50) return out;
  // The chroma mode (histogram summed over 5 x 5 levels).
  double bestMass = -1.0;
  int mu = 128, mv = 128;
  for (int u = 2; u < 254; ++u) {
    for (int v = 2; v < 254; ++v) {
      double mass = 0.0;
      for (int du = -2; du <= 2; ++du)
        for (int dv = -2; dv <= 2; ++dv)
          mass += hist[static_cast<std::size_t>(u + du) * 256 + (v + dv)];
      if (mass > bestMass) {
        bestMass = mass;
        mu = u;
        mv = v;
      }
    }
  }
  // Spread: chroma distances from the mode are Rayleigh for a round cluster (median 1.18 sigma).
  double sigma = 6.0;
  double fu = mu, fv = mv;
  for (int it = 0; it < 4; ++it) {
    const double reach = std::max(6.0, 3.5 * sigma);
    std::vector<double> d, us, vs;
    for (const auto& plane : planes) {
      for (std::size_t i = 0; i < n && i < plane.size(); i += step) {
        if (!mask[i]) continue;
        const double c = std::hypot(plane[i].u - fu, plane[i].v - fv);
        if (c > reach) continue;
        d.push_back(c);
        us.push_back(plane[i].u);
        vs.push_back(plane[i].v);
      }
    }
    if (d.size() < 50) break;
    sigma = std::max(1.0, percentileOf(d, 50.0) / 1.1774);
    fu = percentileOf(us, 50.0);
    fv = percentileOf(vs, 50.0);
  }
  out.u = fu;
  out.v = fv;
  out.chroma_sigma = sigma;
  out.chroma_reach = std::max(4.0, 3.0 * sigma);
  // Luma: the mode of the log luma of the pixels of the floor's chroma, with a robust spread.
  std::vector<double> logs;
  for (const auto& plane : planes) {
    for (std::size_t i = 0; i < n && i < plane.size(); i += step) {
      if (!mask[i] || !out.chromaMatches(plane[i]) || plane[i].y < 2) continue;
      logs.push_back(std::log(static_cast<double>(plane[i].y)));
    }
  }
  if (logs.size() >= 50) {
    const double m = percentileOf(logs, 50.0);
    std::vector<double> dev;
    for (double l : logs)
      dev.push_back(std::abs(l - m));
    const double spread = std::max(std::log(1.35), 4.0 * 1.4826 * percentileOf(dev, 50.0));
    out.luma_lo = std::exp(m - spread);
    out.luma_hi = std::exp(m + spread);
  }
  long matching = 0;
  for (const auto& plane : planes) {
    for (std::size_t i = 0; i < n && i < plane.size(); i += step) {
      if (mask[i] && out.contains(plane[i])) ++matching;
    }
  }
  out.share = static_cast<double>(matching) / static_cast<double>(out.pixels);
  return out;
}

}  // namespace fieldline::calibration
