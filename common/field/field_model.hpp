// The model of the field lines (seed section 4.11, figure 4.16, table 4.4): straight segments and
// circular arcs at the centres of the painted lines, in the field frame (origin at the centre
// spot, x toward the opponent goal, y left; metres, radians), plus goals, penalty marks and the
// carpet up to the barrier. Closest point and distance queries follow eq. 4.74-4.78.
//
// Element order (the seed's table 4.4 for a field that has every element; an element the field
// does not have is left out and the ones after it move up):
//   segments  touch lines (y = +W/2, y = -W/2), x from -L/2 to +L/2
//             goal lines (x = -L/2, x = +L/2), y from -W/2 to +W/2
//             halfway line (x = 0)
//             penalty area front lines (own -x, opponent +x)        if hasPenaltyAreas()
//             goal area front lines (own, opponent)                 if hasGoalAreas()
//             penalty area side lines: own +y, opponent +y, own -y, opponent -y
//             goal area side lines, same order
//   arcs      corner quarter circles at (-L/2,+W/2), (+L/2,+W/2), (+L/2,-W/2), (-L/2,-W/2)
//                                                                    if hasCornerArcs()
//             centre circle                                          if hasCentreCircle()
//             penalty arcs ("D"): own, opponent                      if hasPenaltyArcs()
// where L = length() and W = width() run between line centres. The fu2004 and msl presets have
// the seed's 17 segments and 5 arcs.
//
// A FieldModel is immutable after construction and safe to share between threads.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "common/config/config.hpp"
#include "common/geometry/geometry.hpp"

namespace fieldline::field {

using geometry::Vec2;

// A straight line piece from a to b (line centre), painted `width` wide.
struct LineSegment {
  Vec2 a = Vec2::Zero();
  Vec2 b = Vec2::Zero();
  double width = 0.0;

  double length() const { return (b - a).norm(); }
};

// A circular arc (line centre): the points centre + radius * (cos t, sin t) for t from
// start_angle counter-clockwise through start_angle + sweep. sweep in (0, 2*pi]; 2*pi is a circle.
struct LineArc {
  Vec2 centre = Vec2::Zero();
  double radius = 0.0;
  double start_angle = 0.0;
  double sweep = 0.0;
  double width = 0.0;

  Vec2 pointAt(double angle) const;
  Vec2 startPoint() const { return pointAt(start_angle); }
  Vec2 endPoint() const { return pointAt(start_angle + sweep); }
  // True if the polar angle `angle` (any value) lies on the arc.
  bool contains(double angle) const;
};

enum class GoalColour { kYellow, kBlue, kWhite };
std::string_view goalColourName(GoalColour colour);

// A goal behind a goal line. The mouth lies on the outer edge of the goal line (the line belongs
// to the field); the box reaches `depth` further out.
struct Goal {
  // Centre of the goal mouth, field frame.
  Vec2 mouth_centre = Vec2::Zero();
  // Unit vector from the field into the goal: (-1, 0) for the own goal, (+1, 0) for the opponent's.
  Vec2 outward = Vec2::UnitX();
  // Inner width between the posts, inner depth and height (m).
  double width = 0.0;
  double depth = 0.0;
  double height = 0.0;
  GoalColour colour = GoalColour::kWhite;
};

// The numbers a field is computed from, all between line centres (a loader converts presets that
// measure to the outer edges). Lengths in metres.
struct FieldDimensions {
  std::string name;
  // Goal line to goal line and touch line to touch line, between line centres.
  double length = 0.0;
  double width = 0.0;
  // Width of the inner lines (halfway, circles, areas) and of the boundary (touch, goal) lines.
  double line_width = 0.0;
  double boundary_line_width = 0.0;
  // Carpet from the outer edge of the boundary lines to the barrier.
  double border_width = 0.0;
  // 0: the field has no centre circle / no corner arcs.
  double centre_circle_radius = 0.0;
  double corner_arc_radius = 0.0;
  // Penalty and goal area: depth from the goal line's centre to the front line's centre, width
  // between the side lines' centres. Depth and width 0: the field has no such area.
  double penalty_area_depth = 0.0;
  double penalty_area_width = 0.0;
  double goal_area_depth = 0.0;
  double goal_area_width = 0.0;
  // Penalty arc ("D" of older and lab fields): the part of a circle of this radius around a
  // point penalty_arc_centre_distance from the goal line's centre that lies in front of the
  // penalty area's front line. Radius 0: none (needs a penalty area).
  double penalty_arc_radius = 0.0;
  double penalty_arc_centre_distance = 0.0;
  // Penalty mark centre, from the goal line's centre; no marks when has_penalty_marks is false.
  bool has_penalty_marks = false;
  double penalty_mark_distance = 0.0;
  double penalty_mark_diameter = 0.0;
  double goal_width = 0.0;
  double goal_depth = 0.0;
  double goal_height = 0.0;
  GoalColour own_goal_colour = GoalColour::kBlue;
  GoalColour opponent_goal_colour = GoalColour::kYellow;
};

class FieldModel {
 public:
  // The closest model point to a query point.
  struct Closest {
    Vec2 point = Vec2::Zero();
    double distance = 0.0;
    // Index into segments() or, when is_arc, into arcs().
    int element = -1;
    bool is_arc = false;
  };

  // Builds the model; throws std::invalid_argument for inconsistent dimensions (e.g. a goal
  // area wider than the penalty area). The loader reports such errors with file:line instead.
  explicit FieldModel(const FieldDimensions& dimensions);

  const std::string& name() const { return dims_.name; }
  const FieldDimensions& dimensions() const { return dims_; }
  const std::vector<LineSegment>& segments() const { return segments_; }
  const std::vector<LineArc>& arcs() const { return arcs_; }
  // Width of the inner lines; boundaryLineWidth() for the touch and goal lines.
  double lineWidth() const { return dims_.line_width; }
  double boundaryLineWidth() const { return dims_.boundary_line_width; }
  // Between line centres.
  double length() const { return dims_.length; }
  double width() const { return dims_.width; }
  // Carpet from the outer edge of the boundary lines to the barrier.
  double borderWidth() const { return dims_.border_width; }
  // Half extents of the carpet inside the barrier: x in [-c.x, c.x], y in [-c.y, c.y].
  Vec2 carpetHalfExtent() const;
  // goals()[0] is the own goal (-x), goals()[1] the opponent's (+x).
  const std::vector<Goal>& goals() const { return goals_; }
  // Penalty mark centres (own, opponent); empty if the field has none.
  const std::vector<Vec2>& penaltyMarks() const { return penalty_marks_; }
  // Which optional elements the field has (FieldDimensions: a zero size means none).
  bool hasCentreCircle() const { return dims_.centre_circle_radius > 0.0; }
  bool hasCornerArcs() const { return dims_.corner_arc_radius > 0.0; }
  bool hasPenaltyAreas() const { return dims_.penalty_area_depth > 0.0; }
  bool hasGoalAreas() const { return dims_.goal_area_depth > 0.0; }
  bool hasPenaltyArcs() const { return dims_.penalty_arc_radius > 0.0; }
  // True for a point on the field's carpet between (and on) the touch and goal lines' outer
  // edges, plus `margin` (m) all round (negative: inside).
  bool insideLines(const Vec2& p, double margin = 0.0) const;

  // The closest point on any line centre (eq. 4.74-4.78). Throws std::invalid_argument for a
  // non-finite point.
  Closest closestPoint(const Vec2& p) const;
  // Distance from p to the nearest line centre.
  double distance(const Vec2& p) const { return closestPoint(p).distance; }
  // Points along all lines (centres), segments first then arcs, each element from its start,
  // consecutive points at most `step` apart, both ends included. step > 0.
  std::vector<Vec2> sampleLines(double step) const;

 private:
  FieldDimensions dims_;
  std::vector<LineSegment> segments_;
  std::vector<LineArc> arcs_;
  std::vector<Goal> goals_;
  std::vector<Vec2> penalty_marks_;
};

// Closest point on one segment (eq. 4.74-4.76) and on one arc (eq. 4.77-4.78). For a point at the
// arc's centre every arc point is equally close; the start point is returned.
Vec2 closestPointOnSegment(const LineSegment& segment, const Vec2& p);
Vec2 closestPointOnArc(const LineArc& arc, const Vec2& p);

// Reads a field preset (see config/field/*.yaml and docs/field.md). Throws config::Error naming
// file:line and key path for a missing, unknown or out-of-range key or inconsistent dimensions.
FieldModel loadFieldModel(const config::Node& root);
// Loads a preset by name ("msl", "fu2004", "cnc_lab", ...) or by path to a YAML file.
FieldModel loadFieldPreset(const std::string& name_or_path);

}  // namespace fieldline::field
