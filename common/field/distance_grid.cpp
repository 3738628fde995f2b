#include "common/field/distance_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fieldline::field {
namespace {

constexpr double kMaxNodes = 50e6;

void requireFinite(const Vec2& p, const char* what) {
  if (!p.allFinite())
    throw std::invalid_argument(std::string("DistanceGrid::") + what + ": non-finite point");
}

}  // namespace

DistanceGrid::DistanceGrid(const FieldModel& model, double cell_size, double margin)
    : cell_(cell_size) {
  if (!(std::isfinite(cell_size) && cell_size > 0.0)) {
    throw std::invalid_argument("DistanceGrid: cell_size must be positive");
  }
  if (!(std::isfinite(margin) && margin >= 0.0)) {
    throw std::invalid_argument("DistanceGrid: margin must not be negative");
  }
  // Every line centre lies within the goal lines and touch lines.
  const Vec2 half(model.length() / 2.0 + margin, model.width() / 2.0 + margin);
  const double cols = std::ceil(2.0 * half.x() / cell_size) + 1.0;
  const double rows = std::ceil(2.0 * half.y() / cell_size) + 1.0;
  if (cols * rows > kMaxNodes) {
    throw std::invalid_argument("DistanceGrid: too many nodes; use a larger cell_size");
  }
  cols_ = std::max(2, static_cast<int>(cols));
  rows_ = std::max(2, static_cast<int>(rows));
  origin_ = -half;
  max_corner_ = origin_ + Vec2((cols_ - 1) * cell_, (rows_ - 1) * cell_);
  values_.resize(static_cast<std::size_t>(cols_) * rows_);
  for (int j = 0; j < rows_; ++j) {
    for (int i = 0; i < cols_; ++i) {
      const Vec2 node = origin_ + Vec2(i * cell_, j * cell_);
      values_[static_cast<std::size_t>(j) * cols_ + i] = static_cast<float>(model.distance(node));
    }
  }
}

Vec2 DistanceGrid::clampToGrid(const Vec2& p) const {
  return Vec2(std::clamp(p.x(), origin_.x(), max_corner_.x()),
              std::clamp(p.y(), origin_.y(), max_corner_.y()));
}

DistanceGrid::Cell DistanceGrid::locate(const Vec2& inside) const {
  const double gx = (inside.x() - origin_.x()) / cell_;
  const double gy = (inside.y() - origin_.y()) / cell_;
  // The last row/column of nodes belongs to the cell before it.
  const int i = std::clamp(static_cast<int>(std::floor(gx)), 0, cols_ - 2);
  const int j = std::clamp(static_cast<int>(std::floor(gy)), 0, rows_ - 2);
  return Cell{i,
              j,
              gx - i,
              gy - j,
              nodeValue(i, j),
              nodeValue(i + 1, j),
              nodeValue(i, j + 1),
              nodeValue(i + 1, j + 1)};
}

double DistanceGrid::distance(const Vec2& p) const {
  requireFinite(p, "distance");
  const Vec2 q = clampToGrid(p);
  const Cell c = locate(q);
  const double inside = (1.0 - c.fy) * ((1.0 - c.fx) * c.v00 + c.fx * c.v10) +
                        c.fy * ((1.0 - c.fx) * c.v01 + c.fx * c.v11);
  return inside + (p - q).norm();
}

Vec2 DistanceGrid::gradient(const Vec2& p) const {
  requireFinite(p, "gradient");
  const Vec2 q = clampToGrid(p);
  const Cell c = locate(q);
  Vec2 g(((1.0 - c.fy) * (c.v10 - c.v00) + c.fy * (c.v11 - c.v01)) / cell_,
         ((1.0 - c.fx) * (c.v01 - c.v00) + c.fx * (c.v11 - c.v10)) / cell_);
  // Along a clamped axis the interpolated part is constant; the extension adds the offset's
  // direction.
  const Vec2 offset = p - q;
  if (offset.x() != 0.0) g.x() = 0.0;
  if (offset.y() != 0.0) g.y() = 0.0;
  const double out = offset.norm();
  if (out > 0.0) g += offset / out;
  return g;
}

}  // namespace fieldline::field
