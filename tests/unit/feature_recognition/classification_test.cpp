// Stage 2: straight or curved, line and arc fits, corner splits.
#include "services/feature_recognition/classification.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace classification_test {

using test::contoursOf;

TEST(FitLine, RecoversDirectionOffsetAndExtent) {
  std::mt19937 rng(4);
  const auto points = test::polyline({{1, 1}, {4, 2}}, 0.05, 0.01, rng);
  const Line line = fitLine(points.data(), static_cast<int>(points.size()));
  const Vec2 expected = Vec2(3, 1).normalized();
  EXPECT_GT(line.direction.dot(expected), std::cos(0.01));
  EXPECT_NEAR(line.signedDistance({2.5, 1.5}), 0.0, 0.01);
  EXPECT_NEAR(line.length(), std::sqrt(10.0), 0.05);
  EXPECT_NEAR(line.rms, 0.01, 0.004);
  EXPECT_LT((line.start() - Vec2(1, 1)).norm(), 0.05);
}

TEST(FitArc, RecoversCentreRadiusAndRejectsNonArcs) {
  std::mt19937 rng(5);
  const auto points = test::arc({1, -2}, 2.0, 0.2, 1.4, 0.08, 0.005, rng);
  Arc arc;
  ASSERT_TRUE(fitArc(points.data(), static_cast<int>(points.size()), arc));
  EXPECT_LT((arc.centre - Vec2(1, -2)).norm(), 0.1);
  EXPECT_NEAR(arc.radius, 2.0, 0.05);
  EXPECT_LT(arc.relative_deviation, 0.05);
  // Collinear points have no arc.
  const std::vector<Vec2> line = {{0, 0}, {1, 0}, {2, 0}};
  EXPECT_FALSE(fitArc(line.data(), 3, arc));
}

TEST(Classify, StraightCurvedAndAnLThatIsSplitIntoTwoLines) {
  std::mt19937 rng(6);
  Contours c = contoursOf({test::polyline({{0, 0}, {3, 0}}, 0.1, 0.01, rng),
                           test::arc({0, 0}, 2.0, 0.0, 1.5, 0.1, 0.01, rng),
                           // An L whose corner is too close to the end for the curvature test.
                           test::polyline({{5, 0}, {5, 3}, {5.5, 3}}, 0.1, 0.005, rng)});
  Classified out;
  classifyPieces(c, RecognitionParams{}, out);
  ASSERT_EQ(out.arcs.size(), 1u);
  EXPECT_EQ(out.arcs[0].piece, 1);
  // Three points fix the centre: the radius is rough until the circle stage refits it.
  EXPECT_NEAR(out.arcs[0].radius, 2.0, 0.1);
  // Line 0, and the two legs of the L (the short leg is 0.5 m).
  ASSERT_EQ(out.lines.size(), 3u);
  EXPECT_EQ(out.lines[0].piece, 0);
  EXPECT_NEAR(std::abs(out.lines[0].direction.x()), 1.0, 1e-3);
  int vertical = 0, horizontal = 0;
  for (std::size_t i = 1; i < 3; ++i) {
    if (std::abs(out.lines[i].direction.y()) > 0.99) ++vertical;
    if (std::abs(out.lines[i].direction.x()) > 0.99) ++horizontal;
  }
  EXPECT_EQ(vertical, 1);
  EXPECT_EQ(horizontal, 1);
}

TEST(Classify, ScatteredPointsGiveNeitherLineNorArc) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<Vec2> cloud;
  for (int i = 0; i < 30; ++i)
    cloud.emplace_back(u(rng), u(rng));
  Contours c = contoursOf({cloud});
  Classified out;
  classifyPieces(c, RecognitionParams{}, out);
  for (const Line& line : out.lines)
    EXPECT_LE(line.rms, RecognitionParams{}.max_line_rms);
  for (const Arc& arc : out.arcs)
    EXPECT_LE(arc.relative_deviation, 0.3);
  EXPECT_LT(out.lines.size() + out.arcs.size(), 6u);
}

}  // namespace classification_test
}  // namespace fieldline::feature_recognition
