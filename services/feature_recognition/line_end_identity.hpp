// Penalty corners from one line's end (beyond the seed). From 2-4 m away the goal-area side lines
// (0.75 m) and often the penalty-area side lines show 0-3 line points: too few for a line, so the
// corner is no L-corner, only the end of its front line (or of its side line). The end of a line
// is placed on the field like an L-corner (junction_identity): every end of every model line,
// with the seen line along it, gives a candidate pose, and the model check on the frame's other
// points must pick one, up to the point-symmetric twin, with every rival clearly worse. Two
// checks guard against an end that is no end (the line occluded or too sparsely sampled there):
// the line must have a parallel partner at one of the spacings of the penalty area's lines (a
// corner's front line has the goal line or the other front line beside it), the other points
// must fix the position (the chosen pose shifted by `line_end_shift` along the
// line and across it, each way, fits them clearly worse), and the end must lie within
// `line_end_range` of the robot. And the corner's other line must show at least a point where
// the model puts it (line_end_min_side_points): a line that merely stops has nothing there.
// Only ends placed at a penalty-area or goal-area corner become features.
#pragma once

#include <vector>

#include "services/feature_recognition/junction_identity.hpp"
#include "services/feature_recognition/line_structure.hpp"

namespace fieldline::feature_recognition {

// One end of a seen line: the end point and the unit direction from it into the line (robot
// frame), and the line's seen length.
struct LineEnd {
  Vec2 position = Vec2::Zero();
  Vec2 into = Vec2::UnitX();
  double length = 0.0;
  // The line group it belongs to: (axis, index).
  int axis = 0, group = -1;
  // Whether the group has a parallel partner at one of the area's spacings; without one the
  // corner's other line must show line_end_alone_side_points points.
  bool partner = true;
};

// The ends of the structure's line groups that may be corners: groups with at least
// min_corner_line_points points and min_front_line long, with a parallel group (of as many
// points) at one of the spacings of the penalty area's lines (within spacing_tolerance) or, when
// line_end_alone_side_points > 0, without one (LineEnd::partner false), ends
// within line_end_range of the robot and further than junction_distance from every point in
// `taken` (ends already explained by a junction or a corner).
void candidateLineEnds(const LineStructure& structure, const field::FieldModel& field,
                       const std::vector<Vec2>& taken, const RecognitionParams& params,
                       std::vector<LineEnd>& out);

struct LineEndIdentity {
  JunctionIdentity identity;
  // The other points' best share at the chosen pose shifted along and across the line.
  double shifted_share = 0.0;
  // The corner's position (robot frame) after the chosen pose was refined along the line by the
  // other points (the line's last point is not the corner: the points stop up to a sample
  // spacing short of it).
  Vec2 corner = Vec2::Zero();
  // Points on the first line_end_side_reach metres of the corner's other line, and those as near
  // the corner but on none of its lines (pointsOffLegs: a T or a curve shows some there, an L
  // does not).
  int side_points = 0;
  int beyond_points = 0;
  bool identified = false;
};

// The points 0.1 m to `reach` from `from` along the unit `direction`, within 0.1 m + 2 cm per
// metre of range of that ray (robot frame).
int pointsAlong(const std::vector<Vec2>& points, const Vec2& from, const Vec2& direction,
                double reach);

// The points between `from` and `reach` from `corner` that are not on one of its `legs` (unit
// directions from the corner; within 0.1 m + 2 cm per metre of range of the ray): what an L
// corner's surroundings should not show (robot frame).
int pointsOffLegs(const std::vector<Vec2>& points, const Vec2& corner,
                  const std::vector<Vec2>& legs, double from, double reach);

// pointsOffLegs around `model` (a model junction) placed at the robot pose `robot`: its position
// and legs moved into the robot frame.
int pointsOffJunction(const std::vector<Vec2>& points, const ModelJunction& model,
                      const geometry::Pose2& robot, double from, double reach);

// Places `end` on the field (see the file comment); `models` from modelJunctions(). Returns false
// at once (cheaply) when no model penalty corner fits the other points well enough to be worth
// the full identification.
bool identifyLineEnd(const LineEnd& end, const std::vector<ModelJunction>& models,
                     const std::vector<Vec2>& points, const ModelCheck& check,
                     const RecognitionParams& params, LineEndIdentity& out);

}  // namespace fieldline::feature_recognition
