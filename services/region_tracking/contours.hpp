// Region boundaries: the connectivity grid (seed 3.2) and the closed contours followed on it.
//
// The grid has one point per cell corner, (width+1) x (height+1). Each point holds four bits, one
// per direction of a directed unit edge leaving it. A region's boundary side is stored so that
// the region lies to the right of the edge when walking along it on screen (image y points
// down): outer boundaries run clockwise, boundaries of holes counter-clockwise. Side k of a cell
// (0 up, 1 right, 2 down, 3 left) becomes the edge in direction k (0 +x, 1 +y, 2 -x, 3 -y).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "services/region_tracking/cell_grid.hpp"

namespace fieldline::region_tracking {

// A cell position, compact because the queues hold many of them.
struct Cell {
  std::int16_t x;
  std::int16_t y;
};

// Cell (x, y) of a grid stored with a frame of one extra cell on every side, row-major: the
// neighbours of every real cell exist, so walking from cell to cell needs no bounds checks.
// `width` is the row pitch of the storage: the grid's width + 2, or with kPowerOfTwoPitch the
// next power of two at or above it, so that the coordinates of an index are a mask and a shift
// (the cells beyond the frame on the right of each row are never used).
struct PaddedLayout {
  enum Pitch { kCompactPitch, kPowerOfTwoPitch };
  int width = 0;         // row pitch: grid width + 2, or the power of two at or above it
  int height = 0;        // grid height + 2
  int pitch_shift = -1;  // log2(width) with kPowerOfTwoPitch, else -1

  explicit PaddedLayout(const CellGrid& grid, Pitch pitch = kCompactPitch)
      : width(grid.width + 2), height(grid.height + 2) {
    if (pitch == kPowerOfTwoPitch) {
      pitch_shift = 0;
      while (pitch_shift < 30 && (1 << pitch_shift) < width)
        ++pitch_shift;
      width = 1 << pitch_shift;
    }
  }
  int size() const { return width * height; }
  int index(int x, int y) const { return (y + 1) * width + (x + 1); }
  int x(int index) const { return index % width - 1; }
  int y(int index) const { return index / width - 1; }
  // Index offsets to the neighbour on each side: up, right, down, left.
  int neighbour(int side) const {
    const int offsets[4] = {-width, 1, width, -1};
    return offsets[side];
  }
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
  ClassId class_id = kNoClass;
  // Outer boundary of a region, or the boundary of a hole inside one.
  bool outer = true;
  // Enclosed area in cells: positive for outer boundaries, negative for holes.
  int signed_cell_area = 0;
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

// The corner points are stored with the layout of a cell grid padded by one cell on every
// side (see PaddedLayout): corner (x, y), the top-left corner of cell (x, y), has the same
// index as that cell, so the tracker, which walks padded cell indices, finds the corner of a
// cell side with one addition.
class ConnectivityGrid {
 public:
  explicit ConnectivityGrid(const CellGrid& grid);
  // With the corner points in `layout` (which must be a layout of `grid`), e.g. the power-of-two
  // pitch of the tracker's cells.
  ConnectivityGrid(const CellGrid& grid, const PaddedLayout& layout);

  // Marks side `side` (0 up, 1 right, 2 down, 3 left) of cell (x, y) as a region boundary.
  void addBoundarySide(int x, int y, int side) { addBoundarySideAt(layout_.index(x, y), side); }
  // The same for the cell at padded index `cell`.
  void addBoundarySideAt(int cell, int side) {
    bits_[cell + corner_offset_[side]] |= static_cast<std::uint8_t>(1u << side);
  }
  // Several sides of one cell at once: bit k of `sides` for side k.
  void addBoundarySidesAt(int cell, unsigned sides) {
    for (int side = 0; side < 4; ++side) {
      if (sides & (1u << side)) addBoundarySideAt(cell, side);
    }
  }

  // Follows every closed contour that has an edge on a side of one of `cells`, appends it to
  // `out` with class `class_id`, and removes its edges from the grid. At a grid point with two
  // ways on, the walk turns right first (toward the region), so regions that only touch at a
  // corner get separate contours, as their cells are not 4-connected.
  void extractContours(std::span<const Cell> cells, ClassId class_id, ContourSet& out);
  // The same for cells given as padded indices.
  void extractContoursAt(std::span<const std::int32_t> cells, ClassId class_id, ContourSet& out);

  // True when no edge is left (after all contours have been extracted).
  bool isClear() const;
  // Removes every edge.
  void clear();

 private:
  // Follows the contours of the sides `sides` (bits, as sidesLeft gives them, nonzero) of a cell
  // and of its other sides they leave. Out of line: most cells have no side left.
  [[gnu::noinline]] void extractAround(int cell, unsigned sides, ClassId class_id, ContourSet& out);
  // Bit k set: side k of the cell at padded index `cell` is a boundary edge not yet followed
  // (corner_offset_[0] is 0).
  unsigned sidesLeft(int cell) const {
    return (bits_[cell + corner_offset_[0]] & 1u) | (bits_[cell + corner_offset_[1]] & 2u) |
           (bits_[cell + corner_offset_[2]] & 4u) | (bits_[cell + corner_offset_[3]] & 8u);
  }
  void followContour(int startCorner, int startDirection, ClassId class_id, ContourSet& out);

  CellGrid grid_;
  PaddedLayout layout_;
  // Index offset from a cell to the corner where the edge of each side starts: top-left,
  // top-right, bottom-right, bottom-left; and the index step along each edge direction.
  int corner_offset_[4];
  int step_[4];
  // The turning rule (right, straight, left) for the direction walked and the edges available
  // at the corner reached: the next direction (-1: none) and its index step.
  struct Turn {
    std::int32_t step;
    std::int8_t direction;
  };
  std::array<std::array<Turn, 16>, 4> turns_;
  std::vector<std::uint8_t> bits_;
  // The points of the contour being followed (room for every edge of the grid).
  std::unique_ptr<ContourPoint[]> walk_points_;
};

}  // namespace fieldline::region_tracking
