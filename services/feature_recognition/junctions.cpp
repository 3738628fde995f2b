#include "services/feature_recognition/junctions.hpp"

#include <algorithm>
#include <cmath>

#include "services/feature_recognition/penalty_area.hpp"

namespace fieldline::feature_recognition {

namespace {

enum class Meets { kNot, kEnds, kThrough };

// How `line` meets the point c on it; `away` is set to the unit vector from c along the line
// toward its far end when it ends at c.
Meets howMeets(const Line& line, const Vec2& c, const RecognitionParams& params, Vec2& away) {
  const double s = line.along(c);
  const double jd = params.junction_distance;
  if (s < line.t_min - jd || s > line.t_max + jd) return Meets::kNot;
  if (s - line.t_min >= params.junction_through && line.t_max - s >= params.junction_through) {
    return Meets::kThrough;
  }
  if (std::abs(s - line.t_min) <= jd) {
    away = line.direction;
    return Meets::kEnds;
  }
  if (std::abs(s - line.t_max) <= jd) {
    away = -line.direction;
    return Meets::kEnds;
  }
  return Meets::kNot;
}

// How far `line` reaches from c in direction `dir` (a unit vector along it).
double reach(const Line& line, const Vec2& c, const Vec2& dir) {
  const double s = line.along(c);
  return std::max(0.0, dir.dot(line.direction) > 0 ? line.t_max - s : s - line.t_min);
}

}  // namespace

void findJunctions(const LineStructure& structure, const RecognitionParams& params,
                   std::vector<Junction>& out) {
  out.clear();
  if (!structure.found) return;
  const auto& g0 = structure.groups[0];
  const auto& g1 = structure.groups[1];
  for (int i = 0; i < static_cast<int>(g0.size()); ++i) {
    for (int j = 0; j < static_cast<int>(g1.size()); ++j) {
      // The two lines squared up (one orientation for both, from the better seen one).
      SquareCorner square;
      if (!squareUp(g0[i].line, g1[j].line, params.direction_cluster, square)) continue;
      const Vec2 c = square.position;
      // Each line squared up, over its run at the junction (the group may hold collinear pieces
      // far beyond it: they neither make the line pass through nor lengthen its leg).
      auto atJunction = [&](const LineGroup& group, const Vec2& direction) {
        Line line = group.line;
        const LineRun& run = group.runNear(group.line.along(c));
        const double middle = 0.5 * (group.line.t_min + group.line.t_max);
        line.direction = direction;
        line.centre = group.line.midpoint();
        line.t_min = run.t_min - middle;
        line.t_max = run.t_max - middle;
        return line;
      };
      const Line a = atJunction(g0[i], square.a_direction);
      const Line b = atJunction(g1[j], square.b_direction);
      Vec2 away_a, away_b;
      const Meets ma = howMeets(a, c, params, away_a);
      const Meets mb = howMeets(b, c, params, away_b);
      if (ma == Meets::kNot || mb == Meets::kNot) continue;
      Junction junction;
      junction.position = c;
      if (ma == Meets::kEnds && mb == Meets::kEnds) {
        const Vec2 bisector = away_a + away_b;
        junction.phi = std::atan2(bisector.y(), bisector.x());
        junction = {false, c, junction.phi, 0, i, 1, j};
        junction.leg_count = 2;
        junction.legs = {away_a, away_b, Vec2::Zero()};
        junction.leg_lengths = {reach(a, c, away_a), reach(b, c, away_b), 0.0};
      } else if (ma == Meets::kEnds && mb == Meets::kThrough) {
        junction = {true, c, std::atan2(away_a.y(), away_a.x()), 1, j, 0, i};
        junction.leg_count = 3;
        junction.legs = {away_a, b.direction, -b.direction};
        junction.leg_lengths = {reach(a, c, away_a), reach(b, c, b.direction),
                                reach(b, c, -b.direction)};
      } else if (mb == Meets::kEnds && ma == Meets::kThrough) {
        junction = {true, c, std::atan2(away_b.y(), away_b.x()), 0, i, 1, j};
        junction.leg_count = 3;
        junction.legs = {away_b, a.direction, -a.direction};
        junction.leg_lengths = {reach(b, c, away_b), reach(a, c, a.direction),
                                reach(a, c, -a.direction)};
      } else {
        continue;  // a crossing: no such marking on the field
      }
      out.push_back(junction);
    }
  }
}

}  // namespace fieldline::feature_recognition
