// Penalty corners from one line's end: a goal-area corner whose side line shows a point or two
// (too few for a line) is found from the end of its front line (none at all: refused) (the goal
// line beside it, the rest of the frame placing it); the same end with nothing but parallel lines
// around it is refused (the other points do not fix the position along the line); ends without a
// parallel partner at the area's spacings are no candidates unless line_end_alone_side_points
// asks for more points on the side line instead.
#include "services/feature_recognition/line_end_identity.hpp"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "services/feature_recognition/recognizer.hpp"
#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace line_end_identity_test {

using geometry::Pose2;
using geometry::Vec2;

// Distance of p from the segment a-b.
double segmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double t = std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * d)).norm();
}

// `frame` without its points within `margin` of the field segment a-b (field frame), sequences
// split where points were removed.
perception::LinePoints without(const perception::LinePoints& frame, const Pose2& pose,
                               const Vec2& a, const Vec2& b, double margin) {
  perception::LinePoints out;
  for (const auto& [begin, end] : frame.sequences) {
    std::vector<Vec2> run;
    auto flush = [&] {
      if (run.size() >= 3) test::addSequence(out, run);
      run.clear();
    };
    for (int i = begin; i < end; ++i) {
      const Vec2 local(frame.points[i].x, frame.points[i].y);
      if (segmentDistance(geometry::pointRobotToField(pose, local), a, b) < margin) {
        flush();
      } else {
        run.push_back(local);
      }
    }
    flush();
  }
  return out;
}

// Only the points within `margin` of the field segments given.
perception::LinePoints onlyNear(const perception::LinePoints& frame, const Pose2& pose,
                                const std::vector<std::pair<Vec2, Vec2>>& segments, double margin) {
  perception::LinePoints out;
  for (const auto& [begin, end] : frame.sequences) {
    std::vector<Vec2> run;
    for (int i = begin; i < end; ++i) {
      const Vec2 local(frame.points[i].x, frame.points[i].y);
      const Vec2 p = geometry::pointRobotToField(pose, local);
      for (const auto& [a, b] : segments) {
        if (segmentDistance(p, a, b) < margin) {
          run.push_back(local);
          break;
        }
      }
    }
    if (run.size() >= 3) test::addSequence(out, run);
  }
  return out;
}

std::vector<Vec2> pointsOf(const perception::LinePoints& frame) {
  std::vector<Vec2> out;
  for (const auto& p : frame.points)
    out.emplace_back(p.x, p.y);
  return out;
}

struct GoalArea {
  Vec2 corner;     // the opponent goal's goal-area corner at +y (field frame)
  Vec2 side_end;   // where its side line meets the goal line
  Vec2 front_end;  // the other end of its front line
};

GoalArea goalAreaOf(const field::FieldModel& field) {
  const auto& d = field.dimensions();
  const double x = field.length() / 2 - d.goal_area_depth, y = d.goal_area_width / 2;
  return {Vec2(x, y), Vec2(field.length() / 2, y), Vec2(x, -y)};
}

// The goal-area corner's view used below: every line within 4.5 m.
const Pose2 kGoalAreaView{8.2, 0.6, 0.3};

perception::LinePoints goalAreaFrame(const field::FieldModel& field) {
  return test::frameAt(field, kGoalAreaView, 4.5, 0.12, 0.005);
}

// The goal-area front line's end at the corner, as kGoalAreaView sees it (the line runs along
// field -y into the corner).
LineEnd frontLineEndAtCorner(const GoalArea& area) {
  LineEnd end;
  end.position = geometry::pointFieldToRobot(kGoalAreaView, area.corner);
  end.into = geometry::rotate(Vec2(0.0, -1.0), -kGoalAreaView.phi);
  end.length = 2.0;
  return end;
}

// The frame with the corner's side line cut to its first 0.3 m (two or three points, too short
// for a line).
perception::LinePoints withShortSideLine(const perception::LinePoints& full, const GoalArea& area) {
  const Vec2 side_cut = area.corner + 0.3 * (area.side_end - area.corner).normalized();
  return without(full, kGoalAreaView, side_cut, area.side_end, 0.06);
}

TEST(LineEndIdentity, GoalAreaCornerWithoutItsSideLineIsFoundFromTheFrontLineEnd) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const GoalArea area = goalAreaOf(field);
  const Pose2 truth = kGoalAreaView;
  const perception::LinePoints full = goalAreaFrame(field);
  // The side line shows only its first 0.3 m.
  const perception::LinePoints frame = withShortSideLine(full, area);
  ASSERT_GT(frame.points.size(), 80u);

  // The stage alone, on the front line's end at the corner.
  const ModelCheck check(field, RecognitionParams{});
  const std::vector<ModelJunction> models = modelJunctions(field);
  const LineEnd end = frontLineEndAtCorner(area);
  LineEndIdentity identity;
  ASSERT_TRUE(identifyLineEnd(end, models, pointsOf(frame), check, RecognitionParams{}, identity));
  const ModelJunction& model = models[identity.identity.model];
  EXPECT_TRUE(model.penalty_corner);
  EXPECT_TRUE(model.inner);
  const Pose2& robot = identity.identity.robot;
  const Pose2 twin{-truth.x, -truth.y, truth.phi + std::numbers::pi};
  const double error = std::min((robot.position() - truth.position()).norm(),
                                (robot.position() - twin.position()).norm());
  EXPECT_LT(error, 0.02);
  EXPECT_LT(identity.shifted_share, identity.identity.fit.share() - 0.1);
  EXPECT_GE(identity.side_points, 1);

  // An end without a parallel partner (line_end_alone_side_points) needs that many points on
  // the side line.
  LineEnd alone = end;
  alone.partner = false;
  RecognitionParams alone_params;
  alone_params.line_end_alone_side_points = identity.side_points;
  LineEndIdentity alone_identity;
  EXPECT_TRUE(identifyLineEnd(alone, models, pointsOf(frame), check, alone_params, alone_identity));
  alone_params.line_end_alone_side_points = identity.side_points + 1;
  EXPECT_FALSE(
      identifyLineEnd(alone, models, pointsOf(frame), check, alone_params, alone_identity));

  // Without a single point where the side line should be, the end is not taken for a corner.
  const perception::LinePoints bare = without(full, truth, area.corner, area.side_end, 0.06);
  LineEndIdentity bare_identity;
  EXPECT_FALSE(
      identifyLineEnd(end, models, pointsOf(bare), check, RecognitionParams{}, bare_identity));

  // The whole recogniser finds that corner, only with the line-end rule.
  auto cornerFound = [&](bool line_ends) {
    RecognitionParams params;
    params.line_end_corners = line_ends;
    FeatureRecognizer recognizer(field, params);
    perception::FieldFeatures features;
    recognizer.recognize(frame, features);
    bool found = false;
    for (const auto& h : features.hypotheses) {
      const double e = std::min((h.pose.position() - truth.position()).norm(),
                                (h.pose.position() - twin.position()).norm());
      EXPECT_LT(e, 0.1) << "a hypothesis off the true pose and its twin";
    }
    for (const auto& f : features.features) {
      if (f.kind != perception::FeatureKind::kPenaltyCorner) continue;
      const Vec2 seen = geometry::pointRobotToField(truth, {f.local.x, f.local.y});
      if ((seen - area.corner).norm() < 0.2) found = true;
    }
    return found;
  };
  EXPECT_TRUE(cornerFound(true));
  EXPECT_FALSE(cornerFound(false));
}

// An L, not a T: the same goal-area corner, but with a line crossing the front line's end (the
// side line continued 0.6 m beyond the corner, as the touch line runs on at the halfway line's
// end) is no corner once line_end_max_beyond_points is set; the bare corner has nothing there.
TEST(LineEndIdentity, ASideLineThatContinuesBeyondTheCornerMakesATNotACorner) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const GoalArea area = goalAreaOf(field);
  const Pose2 truth = kGoalAreaView;
  const perception::LinePoints corner_frame = withShortSideLine(goalAreaFrame(field), area);
  const ModelCheck check(field, RecognitionParams{});
  const std::vector<ModelJunction> models = modelJunctions(field);
  const LineEnd end = frontLineEndAtCorner(area);
  RecognitionParams params;
  params.line_end_max_beyond_points = 1;
  LineEndIdentity identity;
  ASSERT_TRUE(identifyLineEnd(end, models, pointsOf(corner_frame), check, params, identity));
  EXPECT_EQ(identity.beyond_points, 0);
  EXPECT_GE(identity.side_points, 2);

  // The side line continued beyond the corner, away from the goal (field -x): points every
  // 0.12 m from 0.12 to 0.6 m, as a line crossing there would show.
  perception::LinePoints t_frame = corner_frame;
  std::vector<Vec2> beyond;
  for (double t = 0.12; t <= 0.6 + 1e-9; t += 0.12) {
    beyond.push_back(geometry::pointFieldToRobot(truth, area.corner - Vec2(t, 0.0)));
  }
  test::addSequence(t_frame, beyond);
  LineEndIdentity t_identity;
  EXPECT_FALSE(identifyLineEnd(end, models, pointsOf(t_frame), check, params, t_identity));
  // (Those within the front line's tolerance of the corner count as on it.)
  EXPECT_GE(t_identity.beyond_points, 3);
  // Without the test (-1; the default is 2) the same end is taken for the corner (the crossing
  // line's points are too few to move the model check).
  RecognitionParams untested_params;
  untested_params.line_end_max_beyond_points = -1;
  LineEndIdentity untested;
  EXPECT_TRUE(identifyLineEnd(end, models, pointsOf(t_frame), check, untested_params, untested));
  // One stray point there (a fragment of clutter) is allowed.
  perception::LinePoints stray_frame = corner_frame;
  test::addSequence(stray_frame, {beyond[2]});
  LineEndIdentity stray_identity;
  EXPECT_TRUE(identifyLineEnd(end, models, pointsOf(stray_frame), check, params, stray_identity));
  EXPECT_EQ(stray_identity.beyond_points, 1);
}

// The geometries of the false hypotheses of 100,000 frames: (frame 87411) the robot by a touch
// line near the halfway line, whose end at the touch line was read as a penalty corner (the
// touch line's points on its one side as the side line); the touch line's other side shows
// there. (Frame 91998) the flat top of the centre circle seen as a line ending where the circle
// turns away, read as a corner: the circle's points beyond that "corner" show there. At a true
// penalty corner nothing does.
TEST(LineEndIdentity, PointsOffTheLegsTellALFromATAndFromTheCircle) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const double half_width = field.width() / 2;
  auto legsAt = [](const Pose2& pose, const std::vector<Vec2>& field_legs) {
    std::vector<Vec2> out;
    for (const Vec2& leg : field_legs)
      out.push_back(geometry::rotate(leg, -pose.phi));
    return out;
  };
  // Frame 87411: the halfway line (x = 0) meets the touch line (y = W/2).
  const Pose2 at_touch_line{2.26, half_width - 1.64, 2.515};
  const auto touch_frame = pointsOf(test::frameAt(field, at_touch_line, 4.5, 0.12, 0.005));
  const Vec2 t_point = geometry::pointFieldToRobot(at_touch_line, {0.0, half_width});
  // Read as a corner: the halfway line into the field, the touch line toward +x as its side.
  const auto t_legs = legsAt(at_touch_line, {Vec2(0.0, -1.0), Vec2(1.0, 0.0)});
  EXPECT_GE(pointsOffLegs(touch_frame, t_point, t_legs, 0.1, 0.6), 3);
  // As the T it is (the touch line both ways): nothing off its legs.
  const auto true_legs = legsAt(at_touch_line, {Vec2(0.0, -1.0), Vec2(1.0, 0.0), Vec2(-1.0, 0.0)});
  EXPECT_EQ(pointsOffLegs(touch_frame, t_point, true_legs, 0.1, 0.6), 0);

  // Frame 91998: the centre circle's top (0, r) seen 4.2 m away; its flat middle 1.1 m long ends
  // 0.55 m from the top, where the circle turns away from the tangent.
  const double r = field.dimensions().centre_circle_radius;
  const Pose2 above_circle{0.82, r + 4.16, -3.04};
  const auto circle_frame = pointsOf(test::frameAt(field, above_circle, 4.8, 0.12, 0.005));
  const Vec2 flat_end = geometry::pointFieldToRobot(above_circle, {-0.6, r});
  const auto arc_legs = legsAt(above_circle, {Vec2(1.0, 0.0), Vec2(0.0, 1.0)});
  EXPECT_GE(pointsOffLegs(circle_frame, flat_end, arc_legs, 0.1, 0.6), 2);

  // A penalty-area corner seen from 3 m: only its two lines there.
  const auto& d = field.dimensions();
  const Vec2 corner(field.length() / 2 - d.penalty_area_depth, d.penalty_area_width / 2);
  const Pose2 before_area{corner.x() - 2.0, corner.y() - 2.2, 0.7};
  const auto area_frame = pointsOf(test::frameAt(field, before_area, 4.5, 0.12, 0.005));
  const auto corner_legs = legsAt(before_area, {Vec2(0.0, -1.0), Vec2(1.0, 0.0)});
  EXPECT_EQ(pointsOffLegs(area_frame, geometry::pointFieldToRobot(before_area, corner), corner_legs,
                          0.1, 0.6),
            0);
}

// The L test of stage 8 (identity_max_beyond_points): a penalty-area corner placed where the
// halfway line meets the touch line (the T read as an L, the touch line's other half unseen as a
// line) shows the touch line's points off the model corner's legs within identity_beyond_reach,
// sampled as densely as the refinement samples near line ends (5 cm); the true corner shows none.
TEST(LineEndIdentity, AnLPlacedAtAPenaltyCornerHasNothingNearItOffItsLegs) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const RecognitionParams params;
  ASSERT_GE(params.identity_max_beyond_points, 0);  // on by default
  const auto& d = field.dimensions();
  const Vec2 corner(field.length() / 2 - d.penalty_area_depth, d.penalty_area_width / 2);
  const std::vector<ModelJunction> models = modelJunctions(field);
  const auto model = std::find_if(models.begin(), models.end(), [&](const ModelJunction& m) {
    return m.penalty_corner && (m.position - corner).norm() < 1e-9;
  });
  ASSERT_NE(model, models.end());
  auto offLegs = [&](const std::vector<Vec2>& points, const Pose2& robot) {
    return pointsOffJunction(points, *model, robot, params.line_end_beyond_from,
                             params.identity_beyond_reach);
  };
  // The true corner from 2 m.
  const Pose2 before_area{corner.x() - 1.4, corner.y() - 1.5, 0.7};
  const auto area_frame = pointsOf(test::frameAt(field, before_area, 4.5, 0.05, 0.005));
  EXPECT_EQ(offLegs(area_frame, before_area), 0);
  // The T (0, W/2) seen from 1.6 m; the pose that puts the model corner on it, its legs along
  // the halfway line (into the field, as the corner's front line) and the touch line toward +x.
  const Vec2 t_point(0.0, field.width() / 2);
  const Pose2 at_touch_line{1.2, t_point.y() - 1.2, 2.5};
  const auto touch_frame = pointsOf(test::frameAt(field, at_touch_line, 4.5, 0.05, 0.005));
  const Vec2 shift = corner - t_point;
  const Pose2 misread{at_touch_line.x + shift.x(), at_touch_line.y + shift.y(), at_touch_line.phi};
  EXPECT_NEAR((geometry::pointFieldToRobot(misread, corner) -
               geometry::pointFieldToRobot(at_touch_line, t_point))
                  .norm(),
              0.0, 1e-9);
  const int t_points = offLegs(touch_frame, misread);
  EXPECT_GT(t_points, params.identity_max_beyond_points);
  // At the true pose the T's own legs include the touch line's other half: nothing off them.
  const std::vector<Vec2> t_legs = {geometry::rotate(Vec2(0.0, -1.0), -at_touch_line.phi),
                                    geometry::rotate(Vec2(1.0, 0.0), -at_touch_line.phi),
                                    geometry::rotate(Vec2(-1.0, 0.0), -at_touch_line.phi)};
  EXPECT_EQ(pointsOffLegs(touch_frame, geometry::pointFieldToRobot(at_touch_line, t_point), t_legs,
                          params.line_end_beyond_from, params.identity_beyond_reach),
            0);
}

// pointsAlong counts the points on a ray from 0.1 m to its reach, within 0.1 m + 2 cm per metre
// of range of it.
TEST(LineEndIdentity, PointsAlongARayCountOnlyThoseNearItWithinItsReach) {
  const Vec2 from(2.0, 0.0), direction(0.0, 1.0);
  const std::vector<Vec2> points = {{2.0, 0.05},   // before 0.1 m
                                    {2.0, 0.2},    // on it
                                    {2.13, 0.4},   // 0.13 m aside, range 2.17 m: tolerance 0.143 m
                                    {2.16, 0.4},   // 0.16 m aside: beyond the tolerance
                                    {2.0, 0.7},    // beyond the reach
                                    {2.0, -0.3}};  // the other way
  EXPECT_EQ(pointsAlong(points, from, direction, 0.6), 2);
  EXPECT_EQ(pointsAlong(points, from, direction, 0.8), 3);
  EXPECT_EQ(pointsAlong(points, from, -direction, 0.6), 1);
}

TEST(LineEndIdentity, AnEndAmongParallelLinesOnlyIsRefused) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const GoalArea area = goalAreaOf(field);
  const auto& d = field.dimensions();
  const Pose2 truth = kGoalAreaView;
  const perception::LinePoints full = goalAreaFrame(field);
  // The goal-area front line and the goal line and penalty-area front line beside it, nothing
  // else: every place along them fits the same.
  const double half = field.length() / 2;
  const perception::LinePoints frame =
      onlyNear(full, truth,
               {{area.corner, area.front_end},
                {Vec2(half, -3.0), Vec2(half, 3.0)},
                {Vec2(half - d.penalty_area_depth, -3.0), Vec2(half - d.penalty_area_depth, 3.0)}},
               0.1);
  ASSERT_GT(frame.points.size(), 60u);
  const LineEnd end = frontLineEndAtCorner(area);
  LineEndIdentity identity;
  EXPECT_FALSE(identifyLineEnd(end, modelJunctions(field), pointsOf(frame),
                               ModelCheck(field, RecognitionParams{}), RecognitionParams{},
                               identity));
}

TEST(LineEndIdentity, CandidateEndsNeedAParallelPartnerAtTheAreasSpacings) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  auto groupAt = [](double t, double from, double to) {
    LineGroup g;
    g.t = t;
    g.line.centre = Vec2(t, 0.0);
    g.line.direction = Vec2::UnitY();
    g.line.t_min = from;
    g.line.t_max = to;
    g.line.count = 10;
    g.runs = {{from, to, 10}};
    return g;
  };
  LineStructure structure;
  structure.found = true;
  // Two parallel lines 0.75 m apart (goal-area depth) and one 3 m away from both.
  structure.groups[0] = {groupAt(1.0, -1.0, 1.5), groupAt(1.75, -3.0, 3.0),
                         groupAt(4.9, -1.0, 1.0)};
  // Lines without a partner give no ends (line_end_alone_side_points 0; the default is 2).
  RecognitionParams partnered;
  partnered.line_end_alone_side_points = 0;
  std::vector<LineEnd> ends;
  candidateLineEnds(structure, field, {}, partnered, ends);
  // Both ends of the first two (within 4.5 m), none of the third.
  ASSERT_EQ(ends.size(), 4u);
  for (const LineEnd& e : ends)
    EXPECT_LT(e.group, 2);
  // An end already explained by a junction is no candidate.
  candidateLineEnds(structure, field, {Vec2(1.0, 1.5)}, partnered, ends);
  EXPECT_EQ(ends.size(), 3u);

  // With line_end_alone_side_points, a line without a partner gives its ends too, marked.
  structure.groups[0][2] = groupAt(4.3, -1.0, 1.0);  // 3.3 and 2.55 m from the others
  candidateLineEnds(structure, field, {}, partnered, ends);
  EXPECT_EQ(ends.size(), 4u);
  RecognitionParams alone;
  alone.line_end_alone_side_points = 2;
  candidateLineEnds(structure, field, {}, alone, ends);
  ASSERT_EQ(ends.size(), 6u);
  for (const LineEnd& e : ends)
    EXPECT_EQ(e.partner, e.group < 2);
  structure.groups[0][2] = groupAt(4.9, -1.0, 1.0);

  // A group seen in two runs (a collinear fragment 2 m beyond the line's end): the line's end
  // is where its run ends, not at the fragment; the fragment (3 points) gives no ends.
  structure.groups[0][0].line.t_max = 3.5;
  structure.groups[0][0].runs = {{-1.0, 1.5, 10}, {3.4, 3.5, 3}};
  candidateLineEnds(structure, field, {}, partnered, ends);
  ASSERT_EQ(ends.size(), 4u);
  EXPECT_NEAR(ends[0].position.y(), -1.0, 1e-9);
  EXPECT_NEAR(ends[1].position.y(), 1.5, 1e-9);
  EXPECT_NEAR(ends[1].length, 2.5, 1e-9);
}

}  // namespace line_end_identity_test
}  // namespace fieldline::feature_recognition
