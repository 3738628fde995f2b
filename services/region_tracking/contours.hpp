// Region boundaries: the connectivity grid (seed 3.2) and the closed contours followed on it.
//
// The grid has one point per cell corner, (width+1) x (height+1). Each point holds four bits, one
// per direction of a directed unit edge leaving it. A region's boundary side is stored so that
// the region lies to the right of the edge when walking along it on screen (image y points
// down): outer boundaries run clockwise, boundaries of holes counter-clockwise. Side k of a cell
// (0 up, 1 right, 2 down, 3 left) becomes the edge in direction k (0 +x, 1 +y, 2 -x, 3 -y).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "services/region_tracking/cell_grid.hpp"

namespace fieldline::region_tracking {

// A cell position, compact because the queues hold many of them.
struct Cell {
  std::int16_t x;
  std::int16_t y;
};

// Neighbour offsets of the four sides, in the order up, right, down, left.
inline constexpr int kSideDx[4] = {0, 1, 0, -1};
inline constexpr int kSideDy[4] = {-1, 0, 1, 0};

// A contour point in pixels: a cell corner times the cell size.
struct ContourPoint {
  int x;
  int y;
  bool operator==(const ContourPoint&) const = default;
};

// One closed boundary; its points are ContourSet::points[begin, end), the last point connects to
// the first.
struct Contour {
  ClassId classId = kNoClass;
  // Outer boundary of a region, or the boundary of a hole inside one.
  bool outer = true;
  // Enclosed area in cells: positive for outer boundaries, negative for holes.
  int signedCellArea = 0;
  int begin = 0;
  int end = 0;
  int size() const { return end - begin; }
};

// The boundaries of one frame. Reused from frame to frame: clear() keeps the memory.
struct ContourSet {
  std::vector<ContourPoint> points;
  std::vector<Contour> contours;

  void clear() {
    points.clear();
    contours.clear();
  }
  std::span<const ContourPoint> pointsOf(const Contour& c) const {
    return std::span<const ContourPoint>(points).subspan(c.begin, c.size());
  }
};

class ConnectivityGrid {
 public:
  explicit ConnectivityGrid(const CellGrid& grid);

  // Marks side `side` (0 up, 1 right, 2 down, 3 left) of cell (x, y) as a region boundary.
  void addBoundarySide(int x, int y, int side) {
    const int cornerX = x + kCornerDx[side];
    const int cornerY = y + kCornerDy[side];
    bits_[cornerY * pointsPerRow_ + cornerX] |= static_cast<std::uint8_t>(1u << side);
  }

  // Follows every closed contour that has an edge on a side of one of `cells`, appends it to
  // `out` with class `classId`, and removes its edges from the grid. At a grid point with two
  // ways on, the walk turns right first (toward the region), so regions that only touch at a
  // corner get separate contours, as their cells are not 4-connected.
  void extractContours(std::span<const Cell> cells, ClassId classId, ContourSet& out);

  // True when no edge is left (after all contours have been extracted).
  bool isClear() const;
  // Removes every edge.
  void clear();

 private:
  // Corner at which the edge of side k starts: top-left, top-right, bottom-right, bottom-left.
  static constexpr int kCornerDx[4] = {0, 1, 1, 0};
  static constexpr int kCornerDy[4] = {0, 0, 1, 1};

  void followContour(int startX, int startY, int startDirection, ClassId classId, ContourSet& out);

  CellGrid grid_;
  int pointsPerRow_;
  std::vector<std::uint8_t> bits_;
};

}  // namespace fieldline::region_tracking
