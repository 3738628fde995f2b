// Stage 6, beyond the seed: where two perpendicular line groups meet. An L-corner is where both
// end (corners of the field and of the areas), a T-junction where one ends on the other (side
// lines on the goal line, the halfway line on a touch line). Long straight lines are kept as
// partial constraints (the robot's distance to a line and the line's direction). None of these
// fixes the pose alone (the field has many of each), so they carry no pose hypothesis here.
#pragma once

#include <array>
#include <vector>

#include "services/feature_recognition/line_structure.hpp"

namespace fieldline::feature_recognition {

struct Junction {
  bool is_t = false;
  // Robot frame.
  Vec2 position = Vec2::Zero();
  // L: the bisector between the two arms; T: along the stem, away from the bar.
  double phi = 0.0;
  // Groups: for a T, `stem` ends on `bar`; for an L the two arms. (axis, index) pairs.
  int bar_axis = 0, bar = -1;
  int stem_axis = 0, stem = -1;
  // The line pieces leaving the junction (robot frame): unit directions and seen lengths, m.
  // L: the two arms; T: the stem, then the bar's two halves.
  int leg_count = 0;
  std::array<Vec2, 3> legs{};
  std::array<double, 3> leg_lengths{};
};

void findJunctions(const LineStructure& structure, const RecognitionParams& params,
                   std::vector<Junction>& out);

}  // namespace fieldline::feature_recognition
