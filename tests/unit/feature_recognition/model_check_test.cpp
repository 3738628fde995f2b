// The model check: the frame's points fit the field at the true pose and at its point-symmetric
// twin, not at a pose turned by 180 degrees about a penalty corner or shifted along the field;
// clutter lowers the share; bad parameters are refused; time is bounded for huge frames.
#include "services/feature_recognition/model_check.hpp"

#include <numbers>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace model_check_test {

using geometry::Pose2;
using geometry::Vec2;
constexpr double kPi = std::numbers::pi;

std::vector<Vec2> pointsOf(const perception::LinePoints& frame) {
  std::vector<Vec2> out;
  for (const auto& p : frame.points)
    out.emplace_back(p.x, p.y);
  return out;
}

TEST(ModelCheck, TruePoseAndTwinFitFlippedAndShiftedPosesDoNot) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const ModelCheck check(field, RecognitionParams{});
  const Pose2 truth{7.5, 1.0, 0.4};
  const auto points = pointsOf(test::frameAt(field, truth, 6.0, 0.05, 0.01));
  ASSERT_GT(points.size(), 200u);
  const ModelFit at_truth = check.fit(points, truth);
  EXPECT_GT(at_truth.share(), 0.97);
  EXPECT_TRUE(check.accepts(at_truth));
  const ModelFit at_twin = check.fit(points, {-truth.x, -truth.y, truth.phi + kPi});
  EXPECT_NEAR(at_twin.share(), at_truth.share(), 0.02);
  // The penalty-area corner nearest the robot (outer, +y) is the mark; the same corner seen with
  // the goal direction flipped puts the robot on the other side of the front line, turned.
  const Vec2 corner(field.length() / 2 - field.dimensions().penalty_area_depth,
                    field.dimensions().penalty_area_width / 2);
  const Vec2 local = geometry::pointFieldToRobot(truth, corner);
  const Pose2 flipped{
      corner.x() - (std::cos(truth.phi + kPi) * local.x() - std::sin(truth.phi + kPi) * local.y()),
      corner.y() - (std::sin(truth.phi + kPi) * local.x() + std::cos(truth.phi + kPi) * local.y()),
      truth.phi + kPi};
  EXPECT_FALSE(check.accepts(check.fit(points, flipped)));
  EXPECT_FALSE(check.accepts(check.fit(points, {truth.x - 1.0, truth.y, truth.phi})));
  EXPECT_FALSE(check.accepts(check.fit(points, {truth.x, truth.y, truth.phi + 0.2})));
}

TEST(ModelCheck, ClutterLowersTheShareAndPointsOutOfRangeAreIgnored) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  RecognitionParams params;
  params.model_check_range = 5.0;
  const ModelCheck check(field, params);
  const Pose2 truth{0.5, -2.0, 1.0};
  auto points = pointsOf(test::frameAt(field, truth, 5.0, 0.05, 0.01));
  const ModelFit clean = check.fit(points, truth);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-4.0, 4.0);
  int added = 0;
  while (added < clean.points) {
    const Vec2 p(u(rng), u(rng));
    if (field.distance(geometry::pointRobotToField(truth, p)) < 0.5 || p.norm() > 5.0) continue;
    points.push_back(p);
    ++added;
  }
  const ModelFit cluttered = check.fit(points, truth);
  EXPECT_EQ(cluttered.points, 2 * clean.points);
  EXPECT_NEAR(cluttered.share(), clean.share() / 2, 0.01);
  EXPECT_FALSE(check.accepts(cluttered));
  // Far points do not count.
  points.assign(50, Vec2(9.0, 0.0));
  EXPECT_EQ(check.fit(points, truth).points, 0);
  EXPECT_FALSE(check.accepts(check.fit(points, truth)));
}

// The goals' shadow (model_check_goal_shadow): points that the goal's posts and frame would give
// (behind the goal line, on rays through the goal) count neither way; the same points seen
// elsewhere, or with the option off, are misfits; a robot standing in the goal has no shadow.
TEST(ModelCheck, PointsInTheGoalsShadowCountNeitherWay) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const field::Goal& goal = field.goals()[1];  // the opponent's, at +x
  const double mouth = goal.mouth_centre.x();
  RecognitionParams params;
  params.model_check_goal_shadow = true;  // the default since features9h, named here
  const ModelCheck with(field, params);
  RecognitionParams counting;
  counting.model_check_goal_shadow = false;
  const ModelCheck without(field, counting);
  const Pose2 robot{mouth - 1.0, 0.3, 0.2};
  const std::vector<Vec2> lines = pointsOf(test::frameAt(field, robot, 5.0, 0.1, 0.005));
  const ModelFit clean = with.fit(lines, robot);
  // The goal's back frame and a post, seen as line points on the floor beyond them.
  std::vector<Vec2> goal_points;
  for (double y = -goal.width / 2; y <= goal.width / 2 + 1e-9; y += 0.1) {
    goal_points.push_back(geometry::pointFieldToRobot(robot, {mouth + goal.depth + 0.3, y}));
  }
  goal_points.push_back(geometry::pointFieldToRobot(robot, {mouth + 0.5, goal.width / 2 + 0.1}));
  std::vector<Vec2> points = lines;
  points.insert(points.end(), goal_points.begin(), goal_points.end());
  const ModelFit shadowed = with.fit(points, robot);
  EXPECT_EQ(shadowed.points, clean.points);
  EXPECT_EQ(shadowed.inliers, clean.inliers);
  const ModelFit counted = without.fit(points, robot);
  EXPECT_EQ(counted.points,
            without.fit(lines, robot).points + static_cast<int>(goal_points.size()));
  EXPECT_LT(counted.share(), clean.share() - 0.05);
  // The goal line's own points in front of the mouth still count (and fit).
  EXPECT_GT(clean.share(), 0.97);
  EXPECT_EQ(clean.points, without.fit(lines, robot).points);

  // The same points in front of the goal line (no goal on their rays) are misfits.
  std::vector<Vec2> field_points = lines;
  for (const Vec2& p : goal_points) {
    field_points.push_back(p - Vec2(goal.depth + 1.5, 0.0));
  }
  const ModelFit in_field = with.fit(field_points, robot);
  EXPECT_EQ(in_field.points, clean.points + static_cast<int>(goal_points.size()));

  // A robot in the goal's mouth sees the goal all around it: nothing is left out.
  const Pose2 in_goal{mouth + 0.2, 0.0, 0.0};
  const std::vector<Vec2> from_goal = pointsOf(test::frameAt(field, in_goal, 5.0, 0.1, 0.005));
  EXPECT_EQ(with.fit(from_goal, in_goal).points, without.fit(from_goal, in_goal).points);
}

TEST(ModelCheck, BoundedWorkAndBadParameters) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  RecognitionParams params;
  params.model_check_max_points = 100;
  const ModelCheck check(field, params);
  const std::vector<Vec2> many(100'000, Vec2(1.0, 0.0));
  EXPECT_LE(check.fit(many, {0, 0, 0}).points, 100);
  RecognitionParams bad;
  bad.model_check_min_share = 1.5;
  EXPECT_THROW(ModelCheck(field, bad), std::invalid_argument);
  bad = RecognitionParams{};
  bad.model_check_tolerance = 0.0;
  EXPECT_THROW(ModelCheck(field, bad), std::invalid_argument);
  bad = RecognitionParams{};
  bad.model_check_cell = -1.0;
  EXPECT_THROW(ModelCheck(field, bad), std::invalid_argument);
}

}  // namespace model_check_test
}  // namespace fieldline::feature_recognition
