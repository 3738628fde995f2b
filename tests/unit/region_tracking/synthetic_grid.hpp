// Synthetic class grids for the region tracking tests: random blobs with holes, shifts, and a
// plain 4-connected labelling to compute what the tracker should find.
#pragma once

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "services/region_tracking/cell_grid.hpp"

namespace fieldline::region_tracking::testing {

struct ClassGrid {
  int width = 0;
  int height = 0;
  std::vector<ClassId> cells;

  ClassGrid(int w, int h, ClassId fill) : width(w), height(h), cells(w * h, fill) {}
  ClassId& at(int x, int y) { return cells[y * width + x]; }
  ClassId at(int x, int y) const { return cells[y * width + x]; }
  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }

  void fillRect(int x0, int y0, int x1, int y1, ClassId c) {
    for (int y = std::max(0, y0); y < std::min(height, y1); ++y) {
      for (int x = std::max(0, x0); x < std::min(width, x1); ++x)
        at(x, y) = c;
    }
  }
  void fillDisk(double cx, double cy, double r, ClassId c) {
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) at(x, y) = c;
      }
    }
  }
  // The grid moved by (dx, dy); cells coming in from outside get `incoming`.
  ClassGrid shifted(int dx, int dy, ClassId incoming) const {
    ClassGrid out(width, height, incoming);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        if (contains(x - dx, y - dy)) out.at(x, y) = at(x - dx, y - dy);
      }
    }
    return out;
  }
};

// Blobs of classes 1 and 2 (disks and rectangles, some with holes of class 0) on class 0.
inline ClassGrid randomBlobs(int w, int h, std::mt19937& rng) {
  ClassGrid grid(w, h, 0);
  std::uniform_real_distribution<double> ux(0, w), uy(0, h), radius(4, 12);
  std::uniform_int_distribution<int> shapes(3, 7), kind(0, 3), cls(1, 2);
  const int n = shapes(rng);
  for (int i = 0; i < n; ++i) {
    const double cx = ux(rng), cy = uy(rng), r = radius(rng);
    const ClassId c = static_cast<ClassId>(cls(rng));
    if (kind(rng) == 0) {
      grid.fillRect(static_cast<int>(cx - r), static_cast<int>(cy - r / 2),
                    static_cast<int>(cx + r), static_cast<int>(cy + r / 2), c);
    } else {
      grid.fillDisk(cx, cy, r, c);
    }
    if (kind(rng) == 1 && r > 7) grid.fillDisk(cx, cy, r / 2.5, 0);  // an island
  }
  return grid;
}

// 4-connected components of the cells where `member(index)` holds: label per cell or -1.
template <typename Member>
int labelComponents(int w, int h, Member member, std::vector<int>& labels) {
  labels.assign(w * h, -1);
  int next = 0;
  std::vector<int> stack;
  for (int start = 0; start < w * h; ++start) {
    if (labels[start] >= 0 || !member(start)) continue;
    labels[start] = next;
    stack.push_back(start);
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      const int x = i % w, y = i / w;
      const int nx[4] = {x, x + 1, x, x - 1}, ny[4] = {y - 1, y, y + 1, y};
      for (int k = 0; k < 4; ++k) {
        if (nx[k] < 0 || ny[k] < 0 || nx[k] >= w || ny[k] >= h) continue;
        const int j = ny[k] * w + nx[k];
        if (labels[j] < 0 && member(j)) {
          labels[j] = next;
          stack.push_back(j);
        }
      }
    }
    ++next;
  }
  return next;
}

}  // namespace fieldline::region_tracking::testing
