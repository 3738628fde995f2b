// A precomputed grid of distances to the nearest field line (the seed's "quality matrix",
// section 4.12, figure 4.18), for fast matching of many line points. Values are exact distances
// at the grid nodes, interpolated bilinearly in between.
#pragma once

#include <vector>

#include "common/field/field_model.hpp"

namespace fieldline::field {

class DistanceGrid {
 public:
  // Covers the lines' bounding box (line centres) grown by `margin` on every side, with nodes
  // `cell_size` apart. Throws std::invalid_argument unless cell_size > 0, margin >= 0 and the
  // grid has at most 50 million nodes.
  DistanceGrid(const FieldModel& model, double cell_size, double margin);

  // Bilinear interpolation of the node distances. Outside the grid: the value at the nearest
  // grid point plus the distance to it (never smaller than the true distance minus one cell).
  // Throws std::invalid_argument for a non-finite point.
  double distance(const Vec2& p) const;
  // Gradient of distance(): the derivative of the bilinear patch (away from the lines it points
  // away from the nearest line with length near 1), outside the grid the derivative of the
  // extension above. Throws std::invalid_argument for a non-finite point.
  Vec2 gradient(const Vec2& p) const;

  double cellSize() const { return cell_; }
  // Lower-left node (field frame) and node counts along x and y.
  Vec2 origin() const { return origin_; }
  int columns() const { return cols_; }
  int rows() const { return rows_; }
  // Distance stored at node (column i, row j).
  double nodeValue(int i, int j) const { return values_[static_cast<std::size_t>(j) * cols_ + i]; }

 private:
  // A point's cell: its lower-left node, the fractions across it, the values at its corners.
  struct Cell {
    int i;
    int j;
    double fx;
    double fy;
    double v00;
    double v10;
    double v01;
    double v11;
  };
  Vec2 clampToGrid(const Vec2& p) const;
  Cell locate(const Vec2& inside) const;

  double cell_;
  Vec2 origin_;
  Vec2 max_corner_;
  int cols_;
  int rows_;
  std::vector<float> values_;
};

}  // namespace fieldline::field
