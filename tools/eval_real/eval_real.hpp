// fieldline-eval-real (issue 30, item 8): every real case (tests/data/real_cases/*.yaml: data
// kept beside the repository in ../shared/data/real, what is known about it) and every rendered
// venue case (tests/data/venue_cases/*.yaml), each run through the tools a team uses, one line of
// figures per case.
//
// Real case manifests (paths relative to the manifest):
//   kind: rings         image, distances (a list or CarpetCalibrator.conf), optional camera
//   kind: line_points   points (text, x y [third column ignored] per line), unit (mm | m),
//                       fields (presets or files: the candidates the points may be from)
//   kind: field_points  points (text, x y per line, field frame), unit, field
// and `name`, `known` (what is known, printed with --verbose), `expect:` bounds.
//
// Expectations (`expect:`; a case whose figure breaks one fails, and the tool exits 1):
//   rings:        max_ring_error_percent (the worst sector's median error at a ring),
//                 max_held_out_percent (an inner ring's distance from the others' curve),
//                 rings (how many rings the tool must match)
//   line_points:  min_on_lines (share of the points within 15 cm of a line at the best pose,
//                 over the best field), no_fit (1: layer 2 must refuse the points on every field)
//   field_points: max_median_cm (median distance of the points to the field's lines)
//   venue:        max_distance_percent (the mirror's distance function, 1-5 m), max_pose_cm,
//                 max_offset_cm, min_precision, min_recall (line points with the calibrated
//                 mirror and table, scored against the truth), ball (1: the ball class must be
//                 found at the ball, within 0.3 m or at its twin), min_ball_found (region
//                 tracking's ball detector with that mirror and table: share of the frames with
//                 the ball in view where it is found within 0.5 m), max_balls_outside (balls it
//                 reports off the field)
#pragma once

#include <string>
#include <vector>

namespace fieldline::evalreal {

struct CaseResult {
  std::string name;
  std::string kind;
  std::string figures;              // the one line
  std::vector<std::string> failed;  // expectations broken (with the figure)
  bool skipped = false;             // data not there
  double seconds = 0.0;
};

// Runs one manifest (real or venue: a venue manifest has `spots:`). Never throws for what the
// case's data does: a tool's refusal is a figure, any other exception the case's failure with
// its reason; throws config::Error for a bad manifest.
CaseResult runCase(const std::string& manifest);

// The manifests of a folder, sorted by name.
std::vector<std::string> manifestsIn(const std::string& folder);

}  // namespace fieldline::evalreal
