#include "tools/calibration_common/grey_image.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace fieldline::calibration {

double GreyImage::sample(double u, double v) const {
  if (!(u >= 0.0 && v >= 0.0 && u <= width - 1 && v <= height - 1)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const int u0 = std::min(static_cast<int>(u), width - 2);
  const int v0 = std::min(static_cast<int>(v), height - 2);
  const double fu = u - u0;
  const double fv = v - v0;
  const auto px = [this](int x, int y) {
    return static_cast<double>(pixels[static_cast<std::size_t>(y) * width + x]);
  };
  return (1 - fv) * ((1 - fu) * px(u0, v0) + fu * px(u0 + 1, v0)) +
         fv * ((1 - fu) * px(u0, v0 + 1) + fu * px(u0 + 1, v0 + 1));
}

GreyImage greyFromFrame(const camera::FrameView& frame) {
  if (!frame.valid()) throw std::invalid_argument("calibration: invalid frame");
  GreyImage g{frame.width, frame.height, {}};
  g.pixels.resize(static_cast<std::size_t>(frame.width) * frame.height);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      g.pixels[static_cast<std::size_t>(v) * frame.width + u] = readYuv(frame, u, v).y;
    }
  }
  return g;
}

}  // namespace fieldline::calibration
