// Colour helpers shared by the simulated camera's files (sim_renderer.cpp, sim_floor.cpp).
#pragma once

#include <algorithm>
#include <cstdint>

#include "common/camera/frame.hpp"

namespace fieldline::camera {

// `c` scaled by `k` (light, texture), rounded and clamped to 0..255.
inline Bgr scaleBgr(Bgr c, double k) {
  auto s = [k](std::uint8_t x) {
    return static_cast<std::uint8_t>(std::clamp(x * k + 0.5, 0.0, 255.0));
  };
  return {s(c.b), s(c.g), s(c.r)};
}

}  // namespace fieldline::camera
