#include "common/field/distance_grid.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

namespace fieldline::field {
namespace distance_grid_test {

class DistanceGridPresets : public ::testing::TestWithParam<const char*> {};

TEST_P(DistanceGridPresets, NodesHoldExactDistances) {
  const FieldModel m = loadFieldPreset(GetParam());
  const DistanceGrid grid(m, 0.1, 0.5);
  for (int j = 0; j < grid.rows(); j += 7) {
    for (int i = 0; i < grid.columns(); i += 5) {
      const Vec2 node = grid.origin() + grid.cellSize() * Vec2(i, j);
      ASSERT_NEAR(grid.nodeValue(i, j), m.distance(node), 1e-5);
      ASSERT_NEAR(grid.distance(node), m.distance(node), 1e-5);
    }
  }
}

TEST_P(DistanceGridPresets, InterpolationStaysWithinACellOfExact) {
  const FieldModel m = loadFieldPreset(GetParam());
  const double cell = 0.05;
  const double margin = 0.5;
  const DistanceGrid grid(m, cell, margin);
  std::mt19937 rng(99);
  const Vec2 half(m.length() / 2 + margin, m.width() / 2 + margin);
  std::uniform_real_distribution<double> x(-half.x(), half.x());
  std::uniform_real_distribution<double> y(-half.y(), half.y());
  double worst = 0.0;
  double sum = 0.0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const Vec2 p(x(rng), y(rng));
    const double error = std::abs(grid.distance(p) - m.distance(p));
    worst = std::max(worst, error);
    sum += error;
  }
  // Distance is 1-Lipschitz, so bilinear interpolation errs by less than half a cell diagonal;
  // away from lines and medial axes it is nearly exact.
  EXPECT_LT(worst, cell * std::sqrt(0.5));
  EXPECT_LT(sum / n, cell / 20);
}

TEST_P(DistanceGridPresets, GradientIsTheDerivativeOfDistance) {
  const FieldModel m = loadFieldPreset(GetParam());
  const DistanceGrid grid(m, 0.1, 1.0);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> x(-m.length() / 2 - 2.0, m.length() / 2 + 2.0);
  std::uniform_real_distribution<double> y(-m.width() / 2 - 2.0, m.width() / 2 + 2.0);
  const double h = 1e-6;
  int checked = 0;
  for (int k = 0; k < 5000; ++k) {
    const Vec2 p(x(rng), y(rng));
    // Skip points within h of a cell border or the grid edge, where the derivative jumps.
    const Vec2 g = (p - grid.origin()) / grid.cellSize();
    const Vec2 frac(g.x() - std::floor(g.x()), g.y() - std::floor(g.y()));
    if (frac.minCoeff() < 1e-4 || frac.maxCoeff() > 1 - 1e-4) continue;
    const Vec2 numeric((grid.distance(p + Vec2(h, 0)) - grid.distance(p - Vec2(h, 0))) / (2 * h),
                       (grid.distance(p + Vec2(0, h)) - grid.distance(p - Vec2(0, h))) / (2 * h));
    ASSERT_NEAR((grid.gradient(p) - numeric).norm(), 0.0, 1e-5) << p.transpose();
    ++checked;
  }
  EXPECT_GT(checked, 4500);
}

INSTANTIATE_TEST_SUITE_P(Field, DistanceGridPresets, ::testing::Values("fu2004", "msl"));

TEST(DistanceGrid, GradientPointsAwayFromTheNearestLine) {
  const FieldModel m = loadFieldPreset("fu2004");
  const DistanceGrid grid(m, 0.02, 0.5);
  // Nearest is the touch line y = 3 (1.0 m away; penalty line 2.0, circle 2.2, halfway 2.5).
  Vec2 g = grid.gradient(Vec2(2.51, 2.01));
  EXPECT_NEAR(g.x(), 0.0, 0.02);
  EXPECT_NEAR(g.y(), -1.0, 0.02);
  // Nearest is the centre circle: gradient along the ray from the centre.
  const Vec2 p(2.51, -0.51);
  g = grid.gradient(p);
  EXPECT_NEAR((g - p.normalized()).norm(), 0.0, 0.02);
  EXPECT_NEAR(grid.distance(p), p.norm() - 1.0, 0.005);
}

TEST(DistanceGrid, OutsideTheGridKeepsGrowing) {
  const FieldModel m = loadFieldPreset("msl");
  const double margin = 0.5;
  const DistanceGrid grid(m, 0.05, margin);
  // 3 m beyond the opponent goal line, on the axis: 2.5 m past the grid's edge.
  const Vec2 far(m.length() / 2 + 3.0, 0.0);
  EXPECT_NEAR(grid.distance(far), 3.0, 0.05);
  EXPECT_NEAR(grid.distance(far), m.distance(far), 0.05);
  const Vec2 g = grid.gradient(far);
  EXPECT_NEAR(g.x(), 1.0, 1e-9);
  EXPECT_NEAR(g.y(), 0.0, 0.05);
  // Diagonal beyond a corner: the exact distance to the corner point.
  const Vec2 corner(m.length() / 2 + 2.0, m.width() / 2 + 2.0);
  EXPECT_NEAR(grid.distance(corner), m.distance(corner), 0.05);
}

TEST(DistanceGrid, CoversTheFieldWithTheMargin) {
  const FieldModel m = loadFieldPreset("fu2004");
  const DistanceGrid grid(m, 0.1, 0.5);
  EXPECT_NEAR(grid.origin().x(), -6.5, 1e-12);
  EXPECT_NEAR(grid.origin().y(), -3.5, 1e-12);
  EXPECT_EQ(grid.columns(), 131);
  EXPECT_EQ(grid.rows(), 71);
}

TEST(DistanceGrid, RejectsBadArguments) {
  const FieldModel m = loadFieldPreset("fu2004");
  EXPECT_THROW(DistanceGrid(m, 0.0, 0.5), std::invalid_argument);
  EXPECT_THROW(DistanceGrid(m, -0.1, 0.5), std::invalid_argument);
  EXPECT_THROW(DistanceGrid(m, 0.1, -1.0), std::invalid_argument);
  EXPECT_THROW(DistanceGrid(m, std::numeric_limits<double>::quiet_NaN(), 0.5),
               std::invalid_argument);
  EXPECT_THROW(DistanceGrid(m, 1e-4, 0.5), std::invalid_argument);  // 1.3e10 nodes
  const DistanceGrid grid(m, 0.1, 0.5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(grid.distance(Vec2(nan, 0)), std::invalid_argument);
  EXPECT_THROW(grid.gradient(Vec2(0, std::numeric_limits<double>::infinity())),
               std::invalid_argument);
}

}  // namespace distance_grid_test
}  // namespace fieldline::field
