#include "services/region_tracking/contours.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <stdexcept>

namespace fieldline::region_tracking {

namespace {
// Unit step of an edge in direction k: +x, +y, -x, -y.
constexpr int kStepDx[4] = {1, 0, -1, 0};
constexpr int kStepDy[4] = {0, 1, 0, -1};

// The turning rule as a table: for the direction just walked and the edges available at the
// corner reached (4 bits), the next direction: right first, then straight, then left; -1 if
// none. Spares the branches of trying the turns one after another.
constexpr std::array<std::array<std::int8_t, 16>, 4> kNextDirection = [] {
  std::array<std::array<std::int8_t, 16>, 4> table{};
  for (int direction = 0; direction < 4; ++direction) {
    for (int available = 0; available < 16; ++available) {
      table[direction][available] = -1;
      for (const int turn : {1, 0, 3}) {
        const int candidate = (direction + turn) & 3;
        if (available & (1 << candidate)) {
          table[direction][available] = static_cast<std::int8_t>(candidate);
          break;
        }
      }
    }
  }
  return table;
}();
}  // namespace

ConnectivityGrid::ConnectivityGrid(const CellGrid& grid)
    : ConnectivityGrid(grid, PaddedLayout(grid)) {}

ConnectivityGrid::ConnectivityGrid(const CellGrid& grid, const PaddedLayout& layout)
    : grid_(grid),
      layout_(layout),
      corner_offset_{0, 1, layout_.width + 1, layout_.width},
      step_{1, layout_.width, -1, -layout_.width},
      bits_(layout_.size(), 0),
      // A contour takes each edge once: at most the four sides of every cell.
      walk_points_(std::make_unique_for_overwrite<ContourPoint[]>(
          4 * static_cast<std::size_t>(layout_.size()))) {
  if (layout.width < grid.width + 2 || layout.height != grid.height + 2) {
    throw std::invalid_argument("connectivity grid: the layout does not fit the grid");
  }
  for (int direction = 0; direction < 4; ++direction) {
    for (int available = 0; available < 16; ++available) {
      const int next = kNextDirection[direction][available];
      turns_[direction][available] = {next < 0 ? 0 : step_[next], static_cast<std::int8_t>(next)};
    }
  }
}

bool ConnectivityGrid::isClear() const {
  return std::all_of(bits_.begin(), bits_.end(), [](std::uint8_t b) { return b == 0; });
}

void ConnectivityGrid::clear() {
  std::fill(bits_.begin(), bits_.end(), 0);
}

void ConnectivityGrid::extractContours(std::span<const Cell> cells, ClassId class_id,
                                       ContourSet& out) {
  for (const Cell cell : cells) {
    const int index = layout_.index(cell.x, cell.y);
    const unsigned sides = sidesLeft(index);
    if (sides != 0) extractAround(index, sides, class_id, out);
  }
}

// Each boundary cell is checked once: a contour through it is followed completely and its
// edges removed, so the next edge found on a later cell always starts a new contour. Most cells
// have no edge left (the contours through them were followed from an earlier cell), so the four
// sides are tested in one go, here in the loop with the grid and the corner offsets in
// registers, and only a cell with an edge left costs a call.
void ConnectivityGrid::extractContoursAt(std::span<const std::int32_t> cells, ClassId class_id,
                                         ContourSet& out) {
  const std::uint8_t* const bits = bits_.data();
  const int right = corner_offset_[1], downRight = corner_offset_[2], down = corner_offset_[3];
  for (const std::int32_t cell : cells) {
    const std::uint8_t* const corner = bits + cell;
    const unsigned sides =
        (corner[0] & 1u) | (corner[right] & 2u) | (corner[downRight] & 4u) | (corner[down] & 8u);
    if (sides != 0) extractAround(cell, sides, class_id, out);
  }
}

void ConnectivityGrid::extractAround(int cell, unsigned sides, ClassId class_id, ContourSet& out) {
  while (sides != 0) {
    const int side = std::countr_zero(sides);
    followContour(cell + corner_offset_[side], side, class_id, out);
    // The contour may have taken other sides of this cell: the later sides are read again.
    sides = sidesLeft(cell) & (~0u << (side + 1));
  }
}

void ConnectivityGrid::followContour(int startCorner, int startDirection, ClassId class_id,
                                     ContourSet& out) {
  Contour contour;
  contour.class_id = class_id;
  contour.begin = static_cast<int>(out.points.size());
  long twiceArea = 0;  // shoelace sum over the edges, in cell units

  // Corner (x, y) has the index of cell (x, y); x and y are carried along with the index. The
  // walk is one chain of dependent loads (corner, its bits, the turn): the step of the next
  // direction comes with the turn, so the chain has no third load, and the check for the start
  // corner is a branch beside it (taken once per contour) rather than a step in it. Points go to
  // a scratch array through a pointer held in a register: a vector's end, reloaded after every
  // byte stored into the grid (a byte may alias anything), would be in the loop's way.
  std::uint8_t* const bits = bits_.data();
  ContourPoint* const first = walk_points_.get();
  ContourPoint* point = first;
  const int cellSize = grid_.cell_size;
  int corner = startCorner;
  int x = layout_.x(startCorner);
  int y = layout_.y(startCorner);
  int direction = startDirection;
  int step = step_[startDirection];
  while (true) {
    bits[corner] &= static_cast<std::uint8_t>(~(1u << direction));
    *point++ = {x * cellSize, y * cellSize};
    const int nextX = x + kStepDx[direction];
    const int nextY = y + kStepDy[direction];
    twiceArea += static_cast<long>(x) * nextY - static_cast<long>(nextX) * y;
    x = nextX;
    y = nextY;
    corner += step;

    // Turning rule: right, straight, left. A U-turn never occurs within one class. (The grid
    // holds the four edge bits only, so `available` indexes the 16 entries as it is.)
    const std::uint8_t available = bits[corner];
    Turn turn = turns_[direction][available];
    if (corner == startCorner) {
      // Back at the start, the (already removed) first edge counts as available: if the turning
      // rule would take it, the contour is closed.
      turn = turns_[direction][available | (1u << startDirection)];
      if (turn.direction == startDirection) break;
    }
    if (turn.direction < 0) break;
    direction = turn.direction;
    step = turn.step;
  }

  out.points.insert(out.points.end(), first, point);
  contour.end = static_cast<int>(out.points.size());
  contour.signed_cell_area = static_cast<int>(twiceArea / 2);
  contour.outer = contour.signed_cell_area > 0;
  out.contours.push_back(contour);
}

}  // namespace fieldline::region_tracking
