// The luma plane of a frame, which the mirror calibration (rings and lines are bright ridges of
// luma) and the colour calibration's ridge search work on.
#pragma once

#include <cstdint>
#include <vector>

#include "common/camera/frame.hpp"

namespace fieldline::calibration {

// A grey (luma) image, row-major.
struct GreyImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;

  // Bilinear sample at (u, v) (pixel centres at integers); NaN outside the image.
  double sample(double u, double v) const;
  std::uint8_t at(int u, int v) const { return pixels[static_cast<std::size_t>(v) * width + u]; }
};
// The luma plane of a frame (YUYV or BGR). Throws std::invalid_argument for an invalid view.
GreyImage greyFromFrame(const camera::FrameView& frame);

}  // namespace fieldline::calibration
