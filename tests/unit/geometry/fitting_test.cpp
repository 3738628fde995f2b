// The shared median and circle fits (common/geometry/fitting.hpp).
#include "common/geometry/fitting.hpp"

#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

namespace fieldline::geometry {
namespace fitting_test {

TEST(Fitting, MedianIsTheUpperMiddleValueAndNaNForNone) {
  EXPECT_DOUBLE_EQ(median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(median({4.0, 1.0, 3.0, 2.0}), 3.0);
  EXPECT_TRUE(std::isnan(median({})));
}

std::vector<Vec2> circlePoints(const Vec2& centre, double radius, int n) {
  std::vector<Vec2> points;
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * std::numbers::pi * k / n;
    points.push_back(centre + radius * Vec2(std::cos(a), std::sin(a)));
  }
  return points;
}

TEST(Fitting, CircleThroughPointsOnACircle) {
  Vec2 centre;
  double radius = 0.0;
  ASSERT_TRUE(fitCircle(circlePoints({3.0, -2.0}, 5.0, 12), centre, radius));
  EXPECT_NEAR(centre.x(), 3.0, 1e-9);
  EXPECT_NEAR(centre.y(), -2.0, 1e-9);
  EXPECT_NEAR(radius, 5.0, 1e-9);
  EXPECT_FALSE(fitCircle(circlePoints({0.0, 0.0}, 1.0, 4), centre, radius)) << "too few points";
}

TEST(Fitting, RobustCircleDropsPointsOffIt) {
  std::vector<Vec2> points = circlePoints({10.0, 20.0}, 50.0, 40);
  points.push_back({10.0, 20.0});  // the centre: 50 px off the circle
  points.push_back({80.0, 20.0});  // 20 px outside
  Vec2 centre;
  double radius = 0.0;
  std::vector<bool> keep;
  ASSERT_TRUE(fitCircleRobust(points, centre, radius, keep, 2.0));
  EXPECT_NEAR(centre.x(), 10.0, 1e-6);
  EXPECT_NEAR(centre.y(), 20.0, 1e-6);
  EXPECT_NEAR(radius, 50.0, 1e-6);
  ASSERT_EQ(keep.size(), points.size());
  EXPECT_FALSE(keep[40]);
  EXPECT_FALSE(keep[41]);
  EXPECT_TRUE(keep[0]);
}

}  // namespace fitting_test
}  // namespace fieldline::geometry
