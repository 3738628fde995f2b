#include "services/region_tracking/floor_lookup.hpp"

#include <algorithm>
#include <cmath>

#include "services/region_tracking/detector_pixels.hpp"

namespace fieldline::region_tracking {

using detail::kNaN;

FloorLookup::FloorLookup(const camera::MirrorModel& mirror)
    : width_(mirror.width()),
      height_(mirror.height()),
      floor_(static_cast<std::size_t>(width_) * height_, FloorXY{kNaN, kNaN}),
      finest_metres_per_pixel_(floor_.size(), kNaN),
      centre_u_(static_cast<float>(mirror.params().centre.x())),
      centre_v_(static_cast<float>(mirror.params().centre.y())),
      self_radius_squared_(static_cast<float>((mirror.params().self_radius + 1.0) *
                                              (mirror.params().self_radius + 1.0))) {
  for (int v = 0; v < height_; ++v) {
    for (int u = 0; u < width_; ++u) {
      if (mirror.dontTouch(u, v)) continue;
      const camera::Vec2 pixel(u, v);
      const std::optional<camera::Vec2> floor = mirror.imageToRobot(pixel);
      if (!floor) continue;
      const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
      floor_[i] = {static_cast<float>(floor->x()), static_cast<float>(floor->y())};
      const camera::Vec2 mpp = mirror.metresPerPixel(pixel);
      finest_metres_per_pixel_[i] = static_cast<float>(std::min(mpp.x(), mpp.y()));
    }
  }
}

std::optional<camera::Vec2> FloorLookup::floorPoint(double u, double v) const {
  const int u0 = static_cast<int>(std::floor(u));
  const int v0 = static_cast<int>(std::floor(v));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= width_ || v0 + 1 >= height_) return std::nullopt;
  const double fu = u - u0;
  const double fv = v - v0;
  const std::size_t i = static_cast<std::size_t>(v0) * width_ + u0;
  const std::size_t corners[4] = {i, i + 1, i + width_, i + width_ + 1};
  const double weights[4] = {(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv};
  double x = 0, y = 0;
  for (int k = 0; k < 4; ++k) {
    x += weights[k] * floor_[corners[k]].x;
    y += weights[k] * floor_[corners[k]].y;
  }
  if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  return camera::Vec2(x, y);
}

bool FloorLookup::floorPoint(float u, float v, float& x, float& y) const {
  if (!(u >= 0.0f && v >= 0.0f)) return false;  // also NaN
  const int u0 = static_cast<int>(u);
  const int v0 = static_cast<int>(v);
  if (u0 + 1 >= width_ || v0 + 1 >= height_) return false;
  const float fu = u - static_cast<float>(u0);
  const float fv = v - static_cast<float>(v0);
  const FloorXY* top = &floor_[static_cast<std::size_t>(v0) * width_ + u0];
  const FloorXY* bottom = top + width_;
  const float topX = top[0].x + fu * (top[1].x - top[0].x);
  const float topY = top[0].y + fu * (top[1].y - top[0].y);
  const float bottomX = bottom[0].x + fu * (bottom[1].x - bottom[0].x);
  const float bottomY = bottom[0].y + fu * (bottom[1].y - bottom[0].y);
  x = topX + fv * (bottomX - topX);
  y = topY + fv * (bottomY - topY);
  return std::isfinite(x) && std::isfinite(y);  // a NaN corner spoils the sum
}

}  // namespace fieldline::region_tracking
