#include "services/feature_recognition/penalty_area.hpp"

#include <algorithm>
#include <cmath>

namespace fieldline::feature_recognition {

double lineOffsetSigma(const Line& line) {
  return line.rms / std::sqrt(static_cast<double>(std::max(line.count, 1)));
}

double lineAngleSigma(const Line& line) {
  // Slope uncertainty of a least-squares line over points spread evenly along its length.
  const double spread = std::max(line.length(), 1e-3) / std::sqrt(12.0);
  return line.rms / (spread * std::sqrt(static_cast<double>(std::max(line.count, 1))));
}

bool intersect(const Line& a, const Line& b, Vec2& out) {
  const double cross = a.direction.x() * b.direction.y() - a.direction.y() * b.direction.x();
  if (std::abs(cross) < 1e-6) return false;
  const Vec2 d = b.centre - a.centre;
  const double s = (d.x() * b.direction.y() - d.y() * b.direction.x()) / cross;
  out = a.centre + s * a.direction;
  return true;
}

namespace {

Vec2 leftOf(const Vec2& v) {
  return Vec2(-v.y(), v.x());
}

// Extent of a line's visible part projected on the unit vector u.
void extentAlong(const Line& line, const Vec2& u, double& lo, double& hi) {
  const double a = line.start().dot(u), b = line.end().dot(u);
  lo = std::min(a, b);
  hi = std::max(a, b);
}

// Looks for the corners at the two ends of `front` (a goal-area or penalty-area front line).
void findCorners(const LineStructure& structure, const PenaltyStructure& area, const Line& front,
                 const Line& goal_line, bool inner, const RecognitionParams& params,
                 std::vector<PenaltyCorner>& out) {
  const Vec2 v = area.toward_goal;
  const Vec2 left = leftOf(v);
  if (front.length() < params.min_front_line) return;
  double front_lo = 0, front_hi = 0;
  extentAlong(front, left, front_lo, front_hi);
  const double front_v = front.midpoint().dot(v);
  const double goal_v = goal_line.midpoint().dot(v);
  const auto& sides = structure.groups[1 - area.axis];
  for (const LineGroup& side_group : sides) {
    const Line& side = side_group.line;
    double lo = 0, hi = 0;
    extentAlong(side, v, lo, hi);
    // The side line starts at the front line and runs toward the goal, not past the goal line.
    if (std::abs(lo - front_v) > params.corner_distance) continue;
    if (hi - lo < params.min_front_line) continue;
    if (hi > goal_v + params.corner_distance) continue;
    Vec2 corner;
    if (!intersect(front, side, corner)) continue;
    const double lateral = corner.dot(left);
    bool is_left;
    if (std::abs(lateral - front_hi) <= params.corner_distance) {
      is_left = true;
    } else if (std::abs(lateral - front_lo) <= params.corner_distance) {
      is_left = false;
    } else {
      continue;
    }
    PenaltyCorner c;
    c.left = is_left;
    c.inner = inner;
    c.position = corner;
    c.toward_goal = v;
    c.sigma_xy = std::hypot(lineOffsetSigma(front), lineOffsetSigma(side));
    c.sigma_phi = lineAngleSigma(front);
    // One corner per end: the closer side line wins.
    auto same = std::find_if(out.begin(), out.end(), [&](const PenaltyCorner& o) {
      return o.inner == inner && o.left == is_left;
    });
    if (same == out.end()) {
      out.push_back(c);
    } else if (std::abs(lateral - (is_left ? front_hi : front_lo)) <
               std::abs(same->position.dot(left) - (is_left ? front_hi : front_lo))) {
      *same = c;
    }
  }
}

}  // namespace

bool findPenaltyArea(const LineStructure& structure, const field::FieldModel& field,
                     const RecognitionParams& params, PenaltyStructure& out) {
  if (!structure.found) return false;
  const auto& dims = field.dimensions();
  const double goal_spacing = dims.goal_area_depth;
  const double penalty_spacing = dims.penalty_area_depth - dims.goal_area_depth;
  const double tol = params.spacing_tolerance;
  bool found = false;
  for (int a = 0; a < 2; ++a) {
    const auto& g = structure.groups[a];
    const int n = static_cast<int>(g.size());
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        for (int k = j + 1; k < n; ++k) {
          const double d1 = g[j].t - g[i].t, d2 = g[k].t - g[j].t;
          // Goal line first (goal toward -axis) or last (toward +axis).
          for (int goal_first = 0; goal_first < 2; ++goal_first) {
            const double e1 = std::abs(d1 - (goal_first ? goal_spacing : penalty_spacing));
            const double e2 = std::abs(d2 - (goal_first ? penalty_spacing : goal_spacing));
            if (e1 > tol || e2 > tol) continue;
            PenaltyStructure s;
            s.axis = a;
            s.goal_line = goal_first ? i : k;
            s.goal_area_line = j;
            s.penalty_line = goal_first ? k : i;
            s.toward_goal = goal_first ? -structure.axes[a] : structure.axes[a];
            s.spacing_error = e1 + e2;
            const Line& goal_area = g[s.goal_area_line].line;
            const Line& penalty = g[s.penalty_line].line;
            const Line& goal_line = g[s.goal_line].line;
            // The front lines are no longer than the areas are wide (seed: the structure no
            // longer than the penalty area).
            const Vec2 left = leftOf(s.toward_goal);
            double ga_lo = 0, ga_hi = 0, pa_lo = 0, pa_hi = 0;
            extentAlong(goal_area, left, ga_lo, ga_hi);
            extentAlong(penalty, left, pa_lo, pa_hi);
            if (ga_hi - ga_lo > dims.goal_area_width + params.length_tolerance) continue;
            if (std::max(ga_hi, pa_hi) - std::min(ga_lo, pa_lo) >
                dims.penalty_area_width + params.length_tolerance) {
              continue;
            }
            // No perpendicular line reaches beyond the goal line.
            const double goal_v = goal_line.midpoint().dot(s.toward_goal);
            bool beyond = false;
            for (const LineGroup& side : structure.groups[1 - a]) {
              double lo = 0, hi = 0;
              extentAlong(side.line, s.toward_goal, lo, hi);
              if (hi > goal_v + params.length_tolerance) beyond = true;
            }
            if (beyond) continue;
            findCorners(structure, s, goal_area, goal_line, true, params, s.corners);
            findCorners(structure, s, penalty, goal_line, false, params, s.corners);
            // Prefer structures with corners, then the most exact spacing.
            const bool better =
                !found || s.corners.size() > out.corners.size() ||
                (s.corners.size() == out.corners.size() && s.spacing_error < out.spacing_error);
            if (better) {
              out = s;
              found = true;
            }
          }
        }
      }
    }
  }
  return found;
}

}  // namespace fieldline::feature_recognition
