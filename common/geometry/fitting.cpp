#include "common/geometry/fitting.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include <Eigen/Dense>

namespace fieldline::geometry {

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

bool fitCircle(const std::vector<Vec2>& points, Vec2& centre, double& radius) {
  if (points.size() < 5) return false;
  Eigen::MatrixXd a(points.size(), 3);
  Eigen::VectorXd b(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    a(row, 0) = points[i].x();
    a(row, 1) = points[i].y();
    a(row, 2) = 1.0;
    b(row) = points[i].squaredNorm();
  }
  const Eigen::Vector3d s = a.colPivHouseholderQr().solve(b);
  centre = Vec2(s(0) / 2, s(1) / 2);
  const double r2 = s(2) + centre.squaredNorm();
  if (!(r2 > 0.0) || !centre.allFinite()) return false;
  radius = std::sqrt(r2);
  return true;
}

bool fitCircleRobust(const std::vector<Vec2>& points, Vec2& centre, double& radius,
                     std::vector<bool>& keep, double gate) {
  keep.assign(points.size(), true);
  std::vector<Vec2> used = points;
  for (int round = 0; round < 3; ++round) {
    if (!fitCircle(used, centre, radius)) return false;
    std::vector<double> residuals;
    for (const Vec2& p : points)
      residuals.push_back(std::abs((p - centre).norm() - radius));
    const double g = round == 0 ? std::max(gate, 3.0 * median(residuals)) : gate;
    used.clear();
    for (std::size_t i = 0; i < points.size(); ++i) {
      keep[i] = residuals[i] <= g;
      if (keep[i]) used.push_back(points[i]);
    }
  }
  return fitCircle(used, centre, radius);
}

}  // namespace fieldline::geometry
