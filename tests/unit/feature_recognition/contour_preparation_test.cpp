// Stage 1: smoothing, curvature, splitting, and the input check.
#include "services/feature_recognition/contour_preparation.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace contour_preparation_test {

using test::addSequence;
using test::polyline;

TEST(Smoothing, KeepsStraightLinesAndEndsAndDampsAZigzag) {
  std::vector<Vec2> line, out(5);
  for (int i = 0; i < 5; ++i)
    line.emplace_back(0.1 * i, 0.2 * i);
  smoothSequence(line.data(), 5, out.data());
  for (int i = 0; i < 5; ++i)
    EXPECT_NEAR((out[i] - line[i]).norm(), 0.0, 1e-12);

  std::vector<Vec2> zigzag;
  for (int i = 0; i < 7; ++i)
    zigzag.emplace_back(0.1 * i, i % 2 ? 0.02 : -0.02);
  std::vector<Vec2> smoothed(7);
  smoothSequence(zigzag.data(), 7, smoothed.data());
  EXPECT_EQ(smoothed.front(), zigzag.front());
  EXPECT_EQ(smoothed.back(), zigzag.back());
  for (int i = 1; i < 6; ++i)
    EXPECT_NEAR(smoothed[i].y(), 0.0, 1e-12);  // 0.25/0.5/0.25
}

TEST(Curvature, TurnsByTheCornerAngleAtTheCornerOnly) {
  std::mt19937 rng(1);
  // An L turning left by 90 degrees at index 10.
  const auto points = polyline({{0, 0}, {1, 0}, {1, 1}}, 0.1, 0.0, rng);
  std::vector<double> turn;
  turningAngles(points.data(), static_cast<int>(points.size()), 4, turn);
  ASSERT_EQ(turn.size(), points.size());
  EXPECT_NEAR(turn[10], std::numbers::pi / 2, 1e-9);
  EXPECT_NEAR(turn[3], 0.0, 1e-9);
  EXPECT_NEAR(turn[17], 0.0, 1e-9);
  std::vector<int> maxima;
  curvatureMaxima(turn, 0.5, 3, maxima);
  ASSERT_EQ(maxima.size(), 1u);
  EXPECT_EQ(maxima[0], 10);
}

TEST(Curvature, MaximaCloserThanTheSeparationMerge) {
  const std::vector<double> turn = {0, 0.6, 0.9, 0.6, 0, 0.7, 0, 0, 0, 0, 0.8, 0};
  std::vector<int> maxima;
  curvatureMaxima(turn, 0.5, 3, maxima);
  // The interval at 5 starts 2 after the one at 1..3 closed: skipped; 10 is far enough.
  EXPECT_EQ(maxima, (std::vector<int>{2, 10}));
}

TEST(PrepareContours, SplitsAPolylineAtItsCornersAndAtGaps) {
  std::mt19937 rng(2);
  perception::LinePoints in;
  addSequence(in, polyline({{0, 0}, {2, 0}, {2, 1.5}}, 0.08, 0.005, rng));
  // A straight run with a jump of 1 m in the middle.
  auto jump = polyline({{3, 0}, {4, 0}}, 0.08, 0.0, rng);
  const auto rest = polyline({{5, 0}, {6, 0}}, 0.08, 0.0, rng);
  jump.insert(jump.end(), rest.begin(), rest.end());
  addSequence(in, jump);
  Contours out;
  const InputCheck check = prepareContours(in, RecognitionParams{}, out);
  EXPECT_EQ(check.errors(), 0);
  EXPECT_EQ(check.sequences_used, 2);
  ASSERT_EQ(out.pieces.size(), 4u);
  // The corner of the L lies between the first two pieces.
  const Vec2 end0 = out.points[out.pieces[0].end - 1];
  const Vec2 start1 = out.points[out.pieces[1].begin];
  EXPECT_LT((end0 - Vec2(2, 0)).norm(), 0.2);
  EXPECT_LT((start1 - Vec2(2, 0)).norm(), 0.2);
  EXPECT_NEAR(out.points[out.pieces[2].end - 1].x(), 4.0, 0.05);
  EXPECT_NEAR(out.points[out.pieces[3].begin].x(), 5.0, 0.05);
}

TEST(PrepareContours, DropsUnsoundSequencesAndUsesTheRest) {
  std::mt19937 rng(3);
  perception::LinePoints in;
  addSequence(in, polyline({{0, 0}, {2, 0}}, 0.1, 0.0, rng));  // 21 points: [0, 21)
  addSequence(in, polyline({{0, 1}, {2, 1}}, 0.1, 0.0, rng));  // [21, 42)
  in.points[30].x = std::numeric_limits<float>::quiet_NaN();
  in.sequences.emplace_back(10, 15);   // overlaps the first
  in.sequences.emplace_back(40, 100);  // past the end
  in.sequences.emplace_back(20, 5);    // backwards
  in.sequences.emplace_back(-3, 2);    // negative
  Contours out;
  const InputCheck check = prepareContours(in, RecognitionParams{}, out);
  EXPECT_EQ(check.sequences_used, 1);
  EXPECT_EQ(check.non_finite, 1);
  EXPECT_EQ(check.overlapping, 1);
  EXPECT_EQ(check.out_of_range, 3);
  EXPECT_EQ(check.errors(), 5);
  EXPECT_FALSE(check.describe().empty());
  ASSERT_EQ(out.pieces.size(), 1u);
  EXPECT_EQ(out.pieces[0].size(), 21);
}

TEST(PrepareContours, RefusesAFrameWithTooManyPointsWhole) {
  perception::LinePoints in;
  in.points.resize(100'000);
  in.sequences.emplace_back(0, 100'000);
  Contours out;
  const InputCheck check = prepareContours(in, RecognitionParams{}, out);
  EXPECT_TRUE(check.too_many_points);
  EXPECT_GT(check.errors(), 0);
  EXPECT_TRUE(out.pieces.empty());
}

TEST(PrepareContours, EmptyFrameIsNoError) {
  Contours out;
  const InputCheck check = prepareContours({}, RecognitionParams{}, out);
  EXPECT_EQ(check.errors(), 0);
  EXPECT_TRUE(out.pieces.empty());
}

}  // namespace contour_preparation_test
}  // namespace fieldline::feature_recognition
