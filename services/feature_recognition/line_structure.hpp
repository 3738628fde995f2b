// Stage 4 (seed 4.13, "Determining the Principal Directions", "Discarding Unreliable and Grouping
// Collinear Lines"): every straight line votes for its direction and the perpendicular one
// (clusters of 0.3 rad, weights = length); the heaviest cluster is the principal direction psi0,
// psi1 = psi0 + 90 degrees. Lines more than 0.3 rad off both are discarded; the rest are grouped
// into collinear groups (their midpoints' projections on the axis within 20 cm), each replaced by
// one line over all its points, and sorted along the axis (topological order).
#pragma once

#include <array>
#include <vector>

#include "services/feature_recognition/classification.hpp"

namespace fieldline::feature_recognition {

// A stretch of a group's line that its members cover: t along LineGroup::line (as
// Line::along), and the points in it.
struct LineRun {
  double t_min = 0.0;
  double t_max = 0.0;
  int count = 0;
  double length() const { return t_max - t_min; }
};

// A group of collinear lines merged into one.
struct LineGroup {
  Line line;
  // The stretches its members cover, sorted along the line; members less than group_run_gap
  // apart form one run. Collinear lines far apart are one group (one field line seen in parts,
  // or a fragment of something else that happens to lie on its extension): where a line ends or
  // meets another, the run there tells it, not the whole group.
  std::vector<LineRun> runs;
  // The run nearest to the point `t` along the line (containing it if any).
  const LineRun& runNear(double t) const;
  // Position of the line along the axis it is perpendicular to, m.
  double t = 0.0;
  // Summed length of the member lines (the visible part), m.
  double support = 0.0;
  std::vector<int> members;  // indices into the input lines
};

struct LineStructure {
  bool found = false;
  // psi0 in [0, pi); axes[0] = (cos psi0, sin psi0), axes[1] = axes[0] turned by +90 degrees.
  double psi0 = 0.0;
  std::array<Vec2, 2> axes{Vec2::UnitX(), Vec2::UnitY()};
  // groups[a]: groups of lines perpendicular to axes[a] (running along axes[1 - a], their
  // direction pointing that way), sorted by t = position along axes[a].
  std::array<std::vector<LineGroup>, 2> groups;
  void clear() {
    found = false;
    groups[0].clear();
    groups[1].clear();
  }
};

// The principal direction in [0, pi) of the lines, weighted by length; false if there are none.
bool principalDirection(const std::vector<Line>& lines, double cluster_angle, double& psi0);

// Builds the structure from `lines` (skipping those whose piece is in `excluded_pieces`). Merged
// lines are refitted to the points of their members' pieces in `contours`.
void buildLineStructure(const Contours& contours, const std::vector<Line>& lines,
                        const std::vector<int>& excluded_pieces, const RecognitionParams& params,
                        LineStructure& out);

}  // namespace fieldline::feature_recognition
