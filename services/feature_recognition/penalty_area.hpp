// Stage 5 (seed 4.13, "Detecting the Corners of the Penalty Area"): among the sorted groups of
// parallel lines, three at the field model's spacings (goal line, goal-area front line,
// penalty-area front line: goal_area_depth and penalty_area_depth - goal_area_depth apart, within
// 20 cm) form the penalty-area structure. The unequal spacings tell the direction toward the goal.
// The front lines may not be longer than the areas are wide, and no line perpendicular to them
// may reach beyond the goal line. A corner is where a perpendicular line (a side line) ends at an
// end of a front line: inner corners on the goal-area line, outer corners on the penalty-area
// line, left and right as seen looking toward the goal.
#pragma once

#include <vector>

#include "common/field/field_model.hpp"
#include "services/feature_recognition/line_structure.hpp"

namespace fieldline::feature_recognition {

struct PenaltyCorner {
  bool left = false;
  // Inner: a goal-area corner; outer: a penalty-area corner.
  bool inner = false;
  // Robot frame.
  Vec2 position = Vec2::Zero();
  // Unit vector toward the goal (perpendicular to the front lines).
  Vec2 toward_goal = Vec2::UnitX();
  // Standard deviations from the fits' residuals, m and rad (no floor applied).
  double sigma_xy = 0.0;
  double sigma_phi = 0.0;
  // The front line and the side line that meet at the corner.
  Line front;
  Line side;
};

struct PenaltyStructure {
  // Axis and group indices (into LineStructure::groups[axis]) of the three lines.
  int axis = 0;
  int goal_line = -1;  // -1: not seen (only the two front lines)
  int goal_area_line = -1;
  int penalty_line = -1;
  Vec2 toward_goal = Vec2::UnitX();
  // Sum of the three spacing errors, m.
  double spacing_error = 0.0;
  std::vector<PenaltyCorner> corners;
};

// Standard deviation of a fitted line's offset across it and of its direction, from its rms
// residual, point count and length.
double lineOffsetSigma(const Line& line);
double lineAngleSigma(const Line& line);

// Intersection of two lines (false if nearly parallel).
bool intersect(const Line& a, const Line& b, Vec2& out);

// Two lines of the field that meet at right angles, fitted together (beyond the seed): one
// orientation for both, each line's own weighted by its information (1 / lineAngleSigma^2, the
// rms floored at 5 mm), so that a short line at a corner takes its direction from the long one.
struct SquareCorner {
  // Where the lines through the two centres, squared up, meet (robot frame).
  Vec2 position = Vec2::Zero();
  // The squared-up directions, each with the sign of its line's own.
  Vec2 a_direction = Vec2::UnitX();
  Vec2 b_direction = Vec2::UnitY();
  // Standard deviation of the common orientation, rad.
  double sigma_phi = 0.0;
};
// False if the lines are further than `max_skew` (rad) from perpendicular.
bool squareUp(const Line& a, const Line& b, double max_skew, SquareCorner& out);

// The best penalty-area structure in `structure`, with its corners; false if there is none.
bool findPenaltyArea(const LineStructure& structure, const field::FieldModel& field,
                     const RecognitionParams& params, PenaltyStructure& out);

}  // namespace fieldline::feature_recognition
