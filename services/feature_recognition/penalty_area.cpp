#include "services/feature_recognition/penalty_area.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

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

bool squareUp(const Line& a, const Line& b, double max_skew, SquareCorner& out) {
  const double ta = std::atan2(a.direction.y(), a.direction.x());
  const double tb = std::atan2(b.direction.y(), b.direction.x());
  // b turned by -90 or +90 degrees, whichever lies nearer a.
  double db = geometry::angleDiff(tb - std::numbers::pi / 2, ta);
  double turn = -std::numbers::pi / 2;
  if (std::abs(db) > std::numbers::pi / 2) {
    db = geometry::angleDiff(tb + std::numbers::pi / 2, ta);
    turn = std::numbers::pi / 2;
  }
  if (std::abs(db) > max_skew) return false;
  auto information = [](const Line& line) {
    Line floored = line;
    floored.rms = std::max(line.rms, 0.005);
    const double sigma = lineAngleSigma(floored);
    return 1.0 / (sigma * sigma);
  };
  const double wa = information(a), wb = information(b);
  const double theta = ta + db * wb / (wa + wb);
  const Vec2 u(std::cos(theta), std::sin(theta));
  out.a_direction = u;
  out.b_direction = geometry::rotate(u, -turn);
  out.position = a.centre + (b.centre - a.centre).dot(u) * u;
  out.sigma_phi = 1.0 / std::sqrt(wa + wb);
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
                 double goal_v, bool inner, bool partial, const RecognitionParams& params,
                 std::vector<PenaltyCorner>& out) {
  const Vec2 v = area.toward_goal;
  const Vec2 left = leftOf(v);
  if (front.length() < params.min_front_line || front.count < params.min_corner_line_points) {
    return;
  }
  double front_lo = 0, front_hi = 0;
  extentAlong(front, left, front_lo, front_hi);
  const double front_v = front.midpoint().dot(v);
  const auto& sides = structure.groups[1 - area.axis];
  for (const LineGroup& side_group : sides) {
    const Line& side = side_group.line;
    double lo = 0, hi = 0;
    extentAlong(side, v, lo, hi);
    // The side line starts at the front line and runs toward the goal, not past the goal line.
    if (std::abs(lo - front_v) > params.corner_distance) continue;
    if (hi - lo < params.min_front_line || side.count < params.min_corner_line_points) continue;
    if (hi > goal_v + params.corner_distance) continue;
    // With only two of the three lines seen the side line must be seen well too: to the goal
    // line (inner corners) or over a metre (outer corners).
    if (partial &&
        hi < std::min(goal_v, front_v + params.partial_side_line) - params.corner_distance) {
      continue;
    }
    // The corner and its orientation from both lines squared up (the front line of a far corner
    // is often short, its own direction poor).
    SquareCorner square;
    if (!squareUp(front, side, params.direction_cluster, square)) continue;
    const Vec2 corner = square.position;
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
    c.toward_goal = square.b_direction.dot(v) >= 0 ? square.b_direction : -square.b_direction;
    c.sigma_xy = std::hypot(lineOffsetSigma(front), lineOffsetSigma(side));
    c.sigma_phi = square.sigma_phi;
    c.front = front;
    c.side = side;
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

namespace {

// The model's segment indices (field_model.hpp) of the goal line, goal-area front line and
// penalty-area front line, own goal and opponent goal.
constexpr int kModelSegments[2][3] = {{2, 7, 5}, {3, 8, 6}};

// True if two parallel lines `spacing` apart and at most `length_a`, `length_b` long can only be
// the lines of roles (role_a, role_b) of one penalty area: every pair of parallel model lines at
// that spacing that is long enough to show them is such a pair.
// Every ordered pair of parallel model segments with their spacing and lengths, computed once per
// field (cached per thread, checked against the field's segments on every call).
struct ParallelPair {
  int i, j;
  double spacing, length_i, length_j;
};

const std::vector<ParallelPair>& parallelPairs(const field::FieldModel& field) {
  thread_local std::vector<field::LineSegment> cached_segments;
  thread_local std::vector<ParallelPair> pairs;
  thread_local bool valid = false;
  const auto& segments = field.segments();
  const bool same = valid && cached_segments.size() == segments.size() &&
                    std::equal(segments.begin(), segments.end(), cached_segments.begin(),
                               [](const field::LineSegment& x, const field::LineSegment& y) {
                                 return x.a == y.a && x.b == y.b;
                               });
  if (same) return pairs;
  cached_segments = segments;
  pairs.clear();
  const int n = static_cast<int>(segments.size());
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if (i == j) continue;
      const Vec2 di = (segments[i].b - segments[i].a).normalized();
      const Vec2 dj = (segments[j].b - segments[j].a).normalized();
      if (std::abs(di.x() * dj.y() - di.y() * dj.x()) > 1e-6) continue;
      const Vec2 d = segments[j].a - segments[i].a;
      pairs.push_back({i, j, std::abs(di.x() * d.y() - di.y() * d.x()), segments[i].length(),
                       segments[j].length()});
    }
  }
  valid = true;
  return pairs;
}

// True if two parallel lines `spacing` apart and at most `length_a`, `length_b` long can only be
// the lines of roles (role_a, role_b) of one penalty area: every pair of parallel model lines at
// that spacing that is long enough to show them is such a pair.
bool onlyPenaltyPair(const field::FieldModel& field, int role_a, int role_b, double spacing,
                     double length_a, double length_b, const RecognitionParams& params) {
  for (const ParallelPair& pair : parallelPairs(field)) {
    if (std::abs(pair.spacing - spacing) > params.spacing_tolerance) continue;
    if (length_a > pair.length_i + params.length_tolerance ||
        length_b > pair.length_j + params.length_tolerance) {
      continue;
    }
    bool explained = false;
    for (const auto& goal : kModelSegments) {
      // Either way round: which side the goal is on is settled by the corners.
      if ((goal[role_a] == pair.i && goal[role_b] == pair.j) ||
          (goal[role_a] == pair.j && goal[role_b] == pair.i)) {
        explained = true;
      }
    }
    if (!explained) return false;
  }
  return true;
}

// Checks one candidate (its lines in s.goal_line, goal_area_line, penalty_line; -1 for a line not
// seen, at most one missing) and finds its corners. False when the candidate is impossible.
bool checkCandidate(const LineStructure& structure, const field::FieldModel& field,
                    const RecognitionParams& params, PenaltyStructure& s) {
  const auto& dims = field.dimensions();
  const auto& g = structure.groups[s.axis];
  const int roles[3] = {s.goal_line, s.goal_area_line, s.penalty_line};
  // Distance of each line from the goal line, toward the field.
  const double offsets[3] = {0.0, dims.goal_area_depth, dims.penalty_area_depth};
  int visible = -1, seen = 0;
  for (int r = 0; r < 3; ++r) {
    if (roles[r] >= 0) {
      visible = r;
      ++seen;
    }
  }
  if (seen < 2) return false;
  const Vec2 v = s.toward_goal;
  const double goal_v = roles[0] >= 0 ? g[roles[0]].line.midpoint().dot(v)
                                      : g[roles[visible]].line.midpoint().dot(v) + offsets[visible];
  // The front lines are no longer than the areas are wide (seed: the structure no longer than
  // the penalty area).
  const Vec2 left = leftOf(v);
  double lo = 1e9, hi = -1e9;
  for (int r = 1; r < 3; ++r) {
    if (roles[r] < 0) continue;
    double a = 0, b = 0;
    extentAlong(g[roles[r]].line, left, a, b);
    if (r == 1 && b - a > dims.goal_area_width + params.length_tolerance) return false;
    lo = std::min(lo, a);
    hi = std::max(hi, b);
  }
  if (hi - lo > dims.penalty_area_width + params.length_tolerance) return false;
  if (seen == 2) {
    int ra = -1, rb = -1;
    for (int r = 0; r < 3; ++r) {
      if (roles[r] < 0) continue;
      (ra < 0 ? ra : rb) = r;
    }
    const Line& a = g[roles[ra]].line;
    const Line& b = g[roles[rb]].line;
    if (!onlyPenaltyPair(field, ra, rb, std::abs(g[roles[rb]].t - g[roles[ra]].t), a.length(),
                         b.length(), params)) {
      return false;
    }
  }
  // No perpendicular line reaches beyond the goal line.
  for (const LineGroup& side : structure.groups[1 - s.axis]) {
    double a = 0, b = 0;
    extentAlong(side.line, v, a, b);
    if (b > goal_v + params.length_tolerance) return false;
  }
  const bool partial = seen < 3;
  if (roles[1] >= 0) {
    findCorners(structure, s, g[roles[1]].line, goal_v, true, partial, params, s.corners);
  }
  if (roles[2] >= 0) {
    findCorners(structure, s, g[roles[2]].line, goal_v, false, partial, params, s.corners);
  }
  // Without all three lines only the corners' side lines tell where the goal is.
  return seen == 3 || !s.corners.empty();
}

}  // namespace

bool findPenaltyArea(const LineStructure& structure, const field::FieldModel& field,
                     const RecognitionParams& params, PenaltyStructure& out) {
  if (!structure.found) return false;
  const auto& dims = field.dimensions();
  // Distance of each line (goal line, goal-area line, penalty-area line) from the goal line.
  const double offsets[3] = {0.0, dims.goal_area_depth, dims.penalty_area_depth};
  const double tol = params.spacing_tolerance;
  bool found = false;
  auto complete = [](const PenaltyStructure& s) {
    return s.goal_line >= 0 && s.goal_area_line >= 0 && s.penalty_line >= 0;
  };
  // `s` has passed checkCandidate.
  auto consider = [&](const PenaltyStructure& s) {
    // Prefer the seed's three lines, then more corners, then the most exact spacing.
    const bool better =
        !found || complete(s) > complete(out) ||
        (complete(s) == complete(out) &&
         (s.corners.size() > out.corners.size() ||
          (s.corners.size() == out.corners.size() && s.spacing_error < out.spacing_error)));
    if (better) {
      out = s;
      found = true;
    }
  };
  auto assign = [](PenaltyStructure& s, int role, int index) {
    (role == 0 ? s.goal_line : role == 1 ? s.goal_area_line : s.penalty_line) = index;
  };
  for (int a = 0; a < 2; ++a) {
    const auto& g = structure.groups[a];
    const int n = static_cast<int>(g.size());
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        const double d1 = g[j].t - g[i].t;
        // Two of the three lines, the goal toward either side: only corners whose side lines run
        // toward the goal tell the side, so both sides having them is no answer.
        for (int ra = 0; ra < 3; ++ra) {
          for (int rb = ra + 1; rb < 3; ++rb) {
            const double spacing = offsets[rb] - offsets[ra];
            if (std::abs(d1 - spacing) > tol) continue;
            PenaltyStructure pair[2];
            int valid = 0;
            for (int toward_plus = 0; toward_plus < 2; ++toward_plus) {
              PenaltyStructure& s = pair[toward_plus];
              s.axis = a;
              s.goal_line = s.goal_area_line = s.penalty_line = -1;
              // Toward +axis the goal-side line (smaller role) has the larger t.
              assign(s, ra, toward_plus ? j : i);
              assign(s, rb, toward_plus ? i : j);
              s.toward_goal = toward_plus ? structure.axes[a] : -structure.axes[a];
              s.spacing_error = std::abs(d1 - spacing);
              if (checkCandidate(structure, field, params, s)) ++valid;
            }
            if (valid != 1) continue;
            for (const PenaltyStructure& s : pair) {
              if (!s.corners.empty()) consider(s);
            }
          }
        }
        for (int k = j + 1; k < n; ++k) {
          const double d2 = g[k].t - g[j].t;
          // Goal line first (goal toward -axis) or last (toward +axis).
          for (int goal_first = 0; goal_first < 2; ++goal_first) {
            const double s1 = offsets[1] - offsets[0], s2 = offsets[2] - offsets[1];
            const double e1 = std::abs(d1 - (goal_first ? s1 : s2));
            const double e2 = std::abs(d2 - (goal_first ? s2 : s1));
            if (e1 > tol || e2 > tol) continue;
            PenaltyStructure s;
            s.axis = a;
            s.goal_line = goal_first ? i : k;
            s.goal_area_line = j;
            s.penalty_line = goal_first ? k : i;
            s.toward_goal = goal_first ? -structure.axes[a] : structure.axes[a];
            s.spacing_error = e1 + e2;
            if (checkCandidate(structure, field, params, s)) consider(s);
          }
        }
      }
    }
  }
  return found;
}

}  // namespace fieldline::feature_recognition
