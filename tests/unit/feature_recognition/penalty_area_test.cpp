// Stage 5: the penalty-area structure and its four kinds of corner, on the lines of the field
// model as robots at various poses see them.
#include "services/feature_recognition/penalty_area.hpp"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "services/feature_recognition/pose_hypotheses.hpp"
#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace penalty_area_test {

using geometry::Pose2;

struct Seen {
  Contours contours;
  Classified classified;
  LineStructure structure;
  PenaltyStructure area;
  bool found = false;
};

Seen look(const field::FieldModel& field, const Pose2& pose, double range) {
  Seen s;
  const auto points = test::frameAt(field, pose, range, 0.08, 0.01);
  prepareContours(points, RecognitionParams{}, s.contours);
  classifyPieces(s.contours, RecognitionParams{}, s.classified);
  buildLineStructure(s.contours, s.classified.lines, {}, RecognitionParams{}, s.structure);
  s.found = findPenaltyArea(s.structure, field, RecognitionParams{}, s.area);
  return s;
}

// Each corner found must be the model's corner of its kind at one of the two goals.
void expectCornersOnTheModel(const field::FieldModel& field, const Pose2& pose, const Seen& s) {
  for (const PenaltyCorner& c : s.area.corners) {
    const Vec2 seen = geometry::pointRobotToField(pose, c.position);
    const auto marks = penaltyCornerMarks(field, c.left, c.inner);
    double best = 1e9;
    for (const Pose2& m : marks)
      best = std::min(best, (seen - m.position()).norm());
    EXPECT_LT(best, 0.05) << "corner left=" << c.left << " inner=" << c.inner << " at "
                          << seen.transpose();
  }
}

TEST(PenaltyArea, AllFourCornersInFrontOfTheOpponentGoal) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const Pose2 pose{7.0, 0.3, 0.2};
  const Seen s = look(field, pose, 6.0);
  ASSERT_TRUE(s.found);
  EXPECT_GE(s.area.goal_line, 0);
  // Toward the goal is field +x.
  const Vec2 v = geometry::vectorRobotToField(pose, s.area.toward_goal);
  EXPECT_GT(v.x(), 0.999);
  EXPECT_EQ(s.area.corners.size(), 4u);
  int left = 0, inner = 0;
  for (const auto& c : s.area.corners) {
    left += c.left;
    inner += c.inner;
  }
  EXPECT_EQ(left, 2);
  EXPECT_EQ(inner, 2);
  expectCornersOnTheModel(field, pose, s);
}

TEST(PenaltyArea, OwnGoalSeenBackwardsTellsLeftFromRightTheOtherWay) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const Pose2 pose{-7.5, -1.0, 2.5};
  const Seen s = look(field, pose, 6.0);
  ASSERT_TRUE(s.found);
  const Vec2 v = geometry::vectorRobotToField(pose, s.area.toward_goal);
  EXPECT_LT(v.x(), -0.999);
  EXPECT_FALSE(s.area.corners.empty());
  expectCornersOnTheModel(field, pose, s);
}

TEST(PenaltyArea, TwoFrontLinesAndASideLineWithoutTheGoalLine) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  // 2.5 m before the penalty-area line: the goal line (4.75 m) is out of a 4.5 m range.
  const double front_x = field.length() / 2 - field.dimensions().penalty_area_depth;
  const Pose2 pose{front_x - 2.5, 2.0, -0.3};
  const Seen s = look(field, pose, 4.5);
  ASSERT_TRUE(s.found);
  EXPECT_EQ(s.area.goal_line, -1);
  EXPECT_FALSE(s.area.corners.empty());
  expectCornersOnTheModel(field, pose, s);
}

TEST(PenaltyArea, TheOtherFieldPresetToo) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  const Pose2 pose{4.0, -0.5, 1.0};
  const Seen s = look(field, pose, 4.0);
  ASSERT_TRUE(s.found);
  EXPECT_FALSE(s.area.corners.empty());
  expectCornersOnTheModel(field, pose, s);
}

TEST(PenaltyArea, NothingAtTheCentreOrAlongATouchLine) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  for (const Pose2& pose : {Pose2{0.0, 0.0, 0.3}, Pose2{-2.0, 6.0, 1.0}, Pose2{3.0, -6.5, 0.0}}) {
    const Seen s = look(field, pose, 5.0);
    EXPECT_FALSE(s.found) << pose.x << "," << pose.y;
  }
}

// A far corner: a long, well seen side line and a short front line of 5 noisy points whose own
// direction is off. Squared up, the corner takes its orientation from the long line, and its
// position is where the squared lines meet.
TEST(SquareUp, TheShortLineTakesItsDirectionFromTheLongOne) {
  const double truth = 0.7;  // the long line's direction, rad
  const Vec2 u(std::cos(truth), std::sin(truth)), n(-u.y(), u.x());
  const Vec2 corner(2.0, 1.0);
  std::mt19937 rng(3);
  std::vector<Vec2> long_points =
      test::polyline({corner + 0.1 * u, corner + 3.0 * u}, 0.1, 0.01, rng);
  // The short line, 0.4 m along n, bent by 0.15 rad.
  const Vec2 bent = geometry::rotate(n, 0.15);
  std::vector<Vec2> short_points =
      test::polyline({corner + 0.05 * bent, corner + 0.4 * bent}, 0.08, 0.0, rng);
  const Line a = fitLine(long_points.data(), static_cast<int>(long_points.size()));
  const Line b = fitLine(short_points.data(), static_cast<int>(short_points.size()));
  SquareCorner square;
  ASSERT_TRUE(squareUp(a, b, 0.3, square));
  const double along = std::atan2(square.a_direction.y(), square.a_direction.x());
  EXPECT_LT(std::abs(geometry::angleDiff(
                along, a.direction.dot(u) > 0 ? truth : truth + std::numbers::pi)),
            0.02);
  EXPECT_NEAR(square.a_direction.dot(square.b_direction), 0.0, 1e-9);
  EXPECT_GT(square.b_direction.dot(b.direction), 0.9);  // the sign of b's own direction kept
  EXPECT_LT((square.position - corner).norm(), 0.05);
  EXPECT_GT(square.sigma_phi, 0.0);
  // Far from perpendicular: refused.
  EXPECT_FALSE(squareUp(a, a, 0.3, square));
}

}  // namespace penalty_area_test
}  // namespace fieldline::feature_recognition
