// Field-line points of one frame (VISION_LINES without LCM): what the region tracker finds and
// what feature recognition and fusion read.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

namespace fieldline::perception {

struct LinePoint {
  // Image position, px (sub-pixel), u to the right, v down.
  float u = 0;
  float v = 0;
  // Floor position in the robot frame, m, x forward, y left.
  float x = 0;
  float y = 0;
};

// Line points of one frame, grouped into sequences that follow a contour (seed 4.13.1).
struct LinePoints {
  std::vector<LinePoint> points;
  // [start, end) into points.
  std::vector<std::pair<int, int>> sequences;
  void clear() {
    points.clear();
    sequences.clear();
  }
};

}  // namespace fieldline::perception
