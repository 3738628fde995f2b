#include "services/region_tracking/contours.hpp"

#include <algorithm>

namespace fieldline::region_tracking {

namespace {
// Unit step of an edge in direction k: +x, +y, -x, -y.
constexpr int kStepDx[4] = {1, 0, -1, 0};
constexpr int kStepDy[4] = {0, 1, 0, -1};
}  // namespace

ConnectivityGrid::ConnectivityGrid(const CellGrid& grid)
    : grid_(grid),
      pointsPerRow_(grid.width + 1),
      bits_(static_cast<std::size_t>(grid.width + 1) * (grid.height + 1), 0) {}

bool ConnectivityGrid::isClear() const {
  return std::all_of(bits_.begin(), bits_.end(), [](std::uint8_t b) { return b == 0; });
}

void ConnectivityGrid::clear() { std::fill(bits_.begin(), bits_.end(), 0); }

void ConnectivityGrid::extractContours(std::span<const Cell> cells, ClassId classId,
                                       ContourSet& out) {
  // Each boundary cell is checked once: a contour through it is followed completely and its
  // edges removed, so the next edge found on a later cell always starts a new contour.
  for (const Cell cell : cells) {
    for (int side = 0; side < 4; ++side) {
      const int cornerX = cell.x + kCornerDx[side];
      const int cornerY = cell.y + kCornerDy[side];
      if (bits_[cornerY * pointsPerRow_ + cornerX] & (1u << side)) {
        followContour(cornerX, cornerY, side, classId, out);
      }
    }
  }
}

void ConnectivityGrid::followContour(int startX, int startY, int startDirection, ClassId classId,
                                     ContourSet& out) {
  Contour contour;
  contour.classId = classId;
  contour.begin = static_cast<int>(out.points.size());
  long twiceArea = 0;  // shoelace sum over the edges, in cell units

  int x = startX;
  int y = startY;
  int direction = startDirection;
  while (true) {
    bits_[y * pointsPerRow_ + x] &= static_cast<std::uint8_t>(~(1u << direction));
    out.points.push_back({x * grid_.cellSize, y * grid_.cellSize});
    const int nextX = x + kStepDx[direction];
    const int nextY = y + kStepDy[direction];
    twiceArea += static_cast<long>(x) * nextY - static_cast<long>(nextX) * y;
    x = nextX;
    y = nextY;

    std::uint8_t available = bits_[y * pointsPerRow_ + x];
    const bool atStart = x == startX && y == startY;
    // Back at the start, the (already removed) first edge counts as available: if the turning
    // rule would take it, the contour is closed.
    if (atStart) available |= static_cast<std::uint8_t>(1u << startDirection);
    // Turning rule: right, straight, left. A U-turn never occurs within one class.
    int next = -1;
    for (const int turn : {1, 0, 3}) {
      const int candidate = (direction + turn) & 3;
      if (available & (1u << candidate)) {
        next = candidate;
        break;
      }
    }
    if (next < 0 || (atStart && next == startDirection)) break;
    direction = next;
  }

  contour.end = static_cast<int>(out.points.size());
  contour.signedCellArea = static_cast<int>(twiceArea / 2);
  contour.outer = contour.signedCellArea > 0;
  out.contours.push_back(contour);
}

}  // namespace fieldline::region_tracking
