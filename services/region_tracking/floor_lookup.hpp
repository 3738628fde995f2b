// Robot-frame floor point of every pixel of an omni camera, precomputed from the mirror model
// for the detectors on the region boundaries.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "common/camera/mirror_model.hpp"

namespace fieldline::region_tracking {

// Robot-frame floor point of every pixel, computed once, so that mapping a detection costs a
// bilinear lookup instead of the mirror's trigonometry.
class FloorLookup {
 public:
  explicit FloorLookup(const camera::MirrorModel& mirror);
  // Floor point (m, robot frame) at a sub-pixel image position; nullopt where any of the four
  // surrounding pixels has no usable floor point.
  std::optional<camera::Vec2> floorPoint(double u, double v) const;
  // The same in single precision for the per-point paths; false where unusable.
  bool floorPoint(float u, float v, float& x, float& y) const;
  // Starts loading the table entries floorPoint(u, v) will read (a hint, no effect otherwise).
  // always_inline: without it GCC 12 emitted no prefetch at all in the detector (measured with
  // objdump), so the hint did nothing.
  [[gnu::always_inline]] void prefetch(float u, float v) const {
    if (!(u >= 0.0f && v >= 0.0f)) return;
    const int u0 = static_cast<int>(u), v0 = static_cast<int>(v);
    if (u0 + 1 >= width_ || v0 + 1 >= height_) return;
    const FloorXY* top = &floor_[static_cast<std::size_t>(v0) * width_ + u0];
    __builtin_prefetch(top);
    __builtin_prefetch(top + 1);
    __builtin_prefetch(top + width_);
    __builtin_prefetch(top + width_ + 1);
  }
  // Smaller of the radial and tangential floor sizes of the pixel, m (NaN where unusable): a
  // floor length L spans at most L / finestMetresPerPixel pixels there.
  float finestMetresPerPixel(int u, int v) const {
    return finest_metres_per_pixel_[v * width_ + u];
  }
  int width() const { return width_; }
  int height() const { return height_; }
  // Inside the robot's own reflection (around the mirror centre, self_radius + 1 px).
  bool inSelf(int u, int v) const {
    const float du = static_cast<float>(u) - centre_u_, dv = static_cast<float>(v) - centre_v_;
    return du * du + dv * dv <= self_radius_squared_;
  }

 private:
  struct FloorXY {
    float x, y;  // NaN where unusable
  };
  int width_;
  int height_;
  // x and y side by side: a bilinear lookup touches two cache lines, not four.
  std::vector<FloorXY> floor_;
  std::vector<float> finest_metres_per_pixel_;
  float centre_u_, centre_v_, self_radius_squared_;
};

}  // namespace fieldline::region_tracking
