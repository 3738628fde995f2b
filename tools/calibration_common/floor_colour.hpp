// The floor's colour from the image alone (issue 30): the dominant colour where the mirror shows
// the floor near the robot. Its chroma is the mode of the pixels' (U, V) histogram, its spread the
// Rayleigh width around it; its luma the mode of the log luma of the pixels of that chroma and a
// robust spread (a grey carpet shares its chroma with black robots, the dark hall and the white
// lines, so luma is part of the floor's colour).
#pragma once

#include <cstdint>
#include <vector>

#include "common/camera/frame.hpp"

namespace fieldline::calibration {

struct FloorColour {
  double u = 128.0, v = 128.0;  // chroma of the mode
  double chroma_sigma = 0.0;    // levels
  double chroma_reach = 0.0;    // a floor pixel's chroma lies within this of (u, v)
  double luma_lo = 0.0, luma_hi = 255.0;
  double share = 0.0;  // of the sampled pixels that have the floor's colour
  long pixels = 0;     // sampled

  bool chromaMatches(const camera::Yuv& c) const;
  bool contains(const camera::Yuv& c) const {
    return chromaMatches(c) && c.y >= luma_lo && c.y <= luma_hi;
  }
};

// The floor's colour over every frame's pixels where `mask` (row-major, one per pixel) is
// nonzero, every `stride`-th pixel. Planes: one YUV per pixel per frame, all of the mask's size.
// Returns share 0 when fewer than 50 pixels were sampled.
FloorColour findFloorColour(const std::vector<std::vector<camera::Yuv>>& planes,
                            const std::vector<std::uint8_t>& mask, int stride = 2);

// A frame's pixels as YUV, row-major.
std::vector<camera::Yuv> yuvPlane(const camera::FrameView& frame);

}  // namespace fieldline::calibration
