// Unseen lines: a pose that puts a line in clear view near the robot where the frame shows no
// point is caught; a line hidden behind something (nothing seen beyond it) or out of range is
// not held against the pose; bad parameters are refused.
#include "services/feature_recognition/unseen_lines.hpp"

#include <algorithm>
#include <stdexcept>

#include <gtest/gtest.h>

#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace unseen_lines_test {

using geometry::Pose2;
using geometry::Vec2;

RecognitionParams checking() {
  RecognitionParams params;
  params.unseen_max_stretch = 1.2;
  return params;
}

// The frame's points (robot frame) of the robot at `pose`, lines within 6 m, every 5 cm.
std::vector<Vec2> frameAt(const field::FieldModel& field, const Pose2& pose) {
  std::vector<Vec2> out;
  for (const auto& p : test::frameAt(field, pose, 6.0, 0.05, 0.01).points)
    out.emplace_back(p.x, p.y);
  return out;
}

// 1.5 m in front of the penalty area's front line, facing the goal: the goal-area and goal
// lines lie beyond the front line on the bearings the test looks along.
struct Scene {
  field::FieldModel field = field::loadFieldPreset("msl");
  double front_x = field.length() / 2 - field.dimensions().penalty_area_depth;
  Pose2 robot{front_x - 1.5, 0.0, 0.0};
};

TEST(UnseenLines, TheTruePoseLeavesNothingUnseen) {
  const Scene s;
  UnseenLines unseen(s.field, checking());
  unseen.index(frameAt(s.field, s.robot));
  EXPECT_LT(unseen.longestUnseen(s.robot), 0.2);
  EXPECT_TRUE(unseen.accepts(unseen.longestUnseen(s.robot)));
}

TEST(UnseenLines, ALineMissingInClearViewIsCaught) {
  const Scene s;
  auto points = frameAt(s.field, s.robot);
  // The front line's points gone (robot frame x = 1.5), the lines beyond it still seen.
  std::erase_if(points, [](const Vec2& p) { return std::abs(p.x() - 1.5) < 0.2; });
  UnseenLines unseen(s.field, checking());
  unseen.index(points);
  // Within 3.5 m the front line runs 2 * sqrt(3.5^2 - 1.5^2) = 6.3 m; the corners of its
  // junctions keep a few neighbours' points near it.
  EXPECT_GT(unseen.longestUnseen(s.robot), 2.0);
  EXPECT_FALSE(unseen.accepts(unseen.longestUnseen(s.robot)));
}

TEST(UnseenLines, ALineHiddenBehindSomethingIsNotHeldAgainstThePose) {
  const Scene s;
  auto points = frameAt(s.field, s.robot);
  // Everything from the front line on is gone, as behind a wall: nothing is seen beyond it.
  std::erase_if(points, [](const Vec2& p) { return p.x() > 1.3; });
  UnseenLines unseen(s.field, checking());
  unseen.index(points);
  EXPECT_LT(unseen.longestUnseen(s.robot), 0.2);
}

TEST(UnseenLines, OnlyLinesWithinRangeCount) {
  const Scene s;
  auto points = frameAt(s.field, s.robot);
  std::erase_if(points, [](const Vec2& p) { return std::abs(p.x() - 1.5) < 0.2; });
  RecognitionParams params = checking();
  params.unseen_range = 1.4;  // the front line is 1.5 m away
  UnseenLines unseen(s.field, params);
  unseen.index(points);
  EXPECT_LT(unseen.longestUnseen(s.robot), 0.2);
}

TEST(UnseenLines, AShiftedPoseLeavesItsLinesUnseen) {
  const Scene s;
  UnseenLines unseen(s.field, checking());
  unseen.index(frameAt(s.field, s.robot));
  // 0.6 m further back: the model's front line falls 2.1 m ahead, where nothing was seen.
  EXPECT_GT(unseen.longestUnseen({s.robot.x - 0.6, s.robot.y, s.robot.phi}), 1.2);
}

TEST(UnseenLines, AStretchAcrossTheCentreCirclesSeamIsOneStretch) {
  const Scene s;
  const auto circle = std::find_if(s.field.arcs().begin(), s.field.arcs().end(),
                                   [](const field::LineArc& a) { return a.sweep > 6.28; });
  ASSERT_NE(circle, s.field.arcs().end());
  // 1.5 m outside the circle where its samples begin and end, facing its centre; the circle's
  // points gone, the halfway line beyond it still seen.
  const Vec2 out(std::cos(circle->start_angle), std::sin(circle->start_angle));
  const Vec2 at = circle->centre + (circle->radius + 1.5) * out;
  const Pose2 robot{at.x(), at.y(), std::atan2(-out.y(), -out.x())};
  auto points = frameAt(s.field, robot);
  std::erase_if(points, [&](const Vec2& p) {
    const Vec2 q = geometry::pointRobotToField(robot, p);
    return std::abs((q - circle->centre).norm() - circle->radius) < 0.1;
  });
  UnseenLines unseen(s.field, checking());
  unseen.index(points);
  // The arc within 3 m of the robot is 4.1 m long (r = 2 m), half of it on each side of the
  // seam: counted as one stretch (without joining the seam: 2.5 m, the longer half).
  EXPECT_GT(unseen.longestUnseen(robot), 3.0);
}

TEST(UnseenLines, OffAcceptsEverythingAndBadParametersAreRefused) {
  const Scene s;
  RecognitionParams off;
  off.unseen_max_stretch = -1.0;
  EXPECT_TRUE(UnseenLines(s.field, off).accepts(100.0));
  const auto refused = [&](auto change) {
    RecognitionParams p = checking();
    change(p);
    EXPECT_THROW(UnseenLines(s.field, p), std::invalid_argument);
  };
  refused([](RecognitionParams& p) { p.unseen_range = 0.0; });
  refused([](RecognitionParams& p) { p.unseen_min_range = 4.0; });
  refused([](RecognitionParams& p) { p.unseen_cover = -0.1; });
  refused([](RecognitionParams& p) { p.unseen_beyond = -1.0; });
  refused([](RecognitionParams& p) { p.unseen_bearing_bin = 0.0; });
  refused([](RecognitionParams& p) { p.unseen_bearing_bin = 2.0; });
}

}  // namespace unseen_lines_test
}  // namespace fieldline::feature_recognition
