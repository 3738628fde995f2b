// Stage 3: arc clustering, re-classification, Landau fit, orientation line.
#include "services/feature_recognition/centre_circle.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace centre_circle_test {

constexpr double kPi = std::numbers::pi;

using test::contoursOf;

TEST(Landau, FitsANoisyCircleFromAFarStart) {
  std::mt19937 rng(8);
  const auto points = test::arc({1.5, -0.5}, 2.0, 0, 2 * kPi, 0.05, 0.01, rng);
  const CircleFit fit = landauFit(points, {1.2, 0.0}, 50);
  EXPECT_LT((fit.centre - Vec2(1.5, -0.5)).norm(), 0.01);
  EXPECT_NEAR(fit.radius, 2.0, 0.01);
  EXPECT_NEAR(fit.rms, 0.014, 0.005);  // sqrt(2) * sigma radially... within noise
}

TEST(Coverage, CountsTheOccupiedSectors) {
  std::mt19937 rng(9);
  const auto quarter = test::arc({0, 0}, 1.0, 0.05, kPi / 2 - 0.05, 0.01, 0.0, rng);
  EXPECT_NEAR(angularCoverage(quarter, {0, 0}), kPi / 2, 0.2);
}

// The centre circle of radius 2 around (3, 1), seen in pieces with gaps (occlusions), one piece
// too flat to count as curved, the halfway line through it and a foreign arc elsewhere.
struct CircleScene {
  Contours contours;
  Classified classified;
  CircleScene(double sigma, std::uint32_t seed) {
    std::mt19937 rng(seed);
    const Vec2 m(3, 1);
    contours = contoursOf({test::arc(m, 2.0, 0.1, 1.3, 0.08, sigma, rng),
                           test::arc(m, 2.0, 1.8, 2.9, 0.08, sigma, rng),
                           test::arc(m, 2.0, 3.6, 4.7, 0.08, sigma, rng),
                           // 0.35 rad of circle: classified straight.
                           test::arc(m, 2.0, 5.3, 5.65, 0.08, sigma, rng),
                           test::polyline({{3, -2.5}, {3, 4.5}}, 0.1, sigma, rng),
                           // A corner arc (radius 0.75) far away.
                           test::arc({-4, -3}, 0.75, 0.0, 1.5, 0.05, sigma, rng)});
    classifyPieces(contours, RecognitionParams{}, classified);
  }
};

TEST(FindCircle, FindsTheCircleFromArcsAndRecoversMisclassifiedPieces) {
  CircleScene scene(0.01, 10);
  // The flat piece is straight before the circle is known.
  bool flat_is_straight = false;
  for (int k : scene.classified.straight_pieces)
    flat_is_straight |= k == 3;
  ASSERT_TRUE(flat_is_straight);
  CentreCircle circle;
  findCircle(scene.contours, scene.classified, 2.0, RecognitionParams{}, circle);
  ASSERT_TRUE(circle.found);
  EXPECT_LT((circle.fit.centre - Vec2(3, 1)).norm(), 0.02);
  EXPECT_NEAR(circle.fit.radius, 2.0, 0.02);
  EXPECT_NE(std::find(circle.pieces.begin(), circle.pieces.end(), 3), circle.pieces.end());
  EXPECT_EQ(std::find(circle.pieces.begin(), circle.pieces.end(), 5), circle.pieces.end());
  EXPECT_FALSE(circle.oriented);

  // The halfway line through the centre orients it; the centre moves onto the line.
  findOrientationLine(scene.classified.lines, RecognitionParams{}, circle);
  ASSERT_TRUE(circle.oriented);
  EXPECT_GT(std::abs(circle.line_direction.y()), std::cos(0.01));
  EXPECT_NEAR(circle.fit.centre.x(), 3.0, 0.01);
}

TEST(FindCircle, NoCircleOfAnotherRadiusOrFromTooFewPoints) {
  CircleScene scene(0.01, 11);
  CentreCircle circle;
  findCircle(scene.contours, scene.classified, 3.0, RecognitionParams{}, circle);
  EXPECT_FALSE(circle.found);
  // One short arc alone is below the 20 points the seed asks for.
  std::mt19937 rng(12);
  Contours lone = contoursOf({test::arc({0, 0}, 2.0, 0.0, 1.0, 0.12, 0.0, rng)});
  Classified classified;
  classifyPieces(lone, RecognitionParams{}, classified);
  ASSERT_EQ(classified.arcs.size(), 1u);
  findCircle(lone, classified, 2.0, RecognitionParams{}, circle);
  EXPECT_FALSE(circle.found);
}

TEST(FindOrientationLine, IgnoresLinesPassingBesideTheCentre) {
  CircleScene scene(0.01, 13);
  CentreCircle circle;
  findCircle(scene.contours, scene.classified, 2.0, RecognitionParams{}, circle);
  ASSERT_TRUE(circle.found);
  std::mt19937 rng(14);
  const auto beside = test::polyline({{3.6, -2.5}, {3.6, 4.5}}, 0.1, 0.0, rng);
  std::vector<Line> lines = {fitLine(beside.data(), static_cast<int>(beside.size()))};
  findOrientationLine(lines, RecognitionParams{}, circle);
  EXPECT_FALSE(circle.oriented);
}

}  // namespace centre_circle_test
}  // namespace fieldline::feature_recognition
