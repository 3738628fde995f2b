#include "services/feature_recognition/line_structure.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace fieldline::feature_recognition {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kMaxGroups = 40;

// a - b modulo pi in [-pi/2, pi/2).
double directionDiff(double a, double b) {
  double d = std::fmod(a - b + kPi / 2, kPi);
  if (d < 0) d += kPi;
  return d - kPi / 2;
}

double wrapPi(double a) {
  double r = std::fmod(a, kPi);
  if (r < 0) r += kPi;
  return r;
}

}  // namespace

bool principalDirection(const std::vector<Line>& lines, double cluster_angle, double& psi0) {
  struct Cluster {
    double angle;
    double weight;
  };
  thread_local std::vector<Cluster> clusters;
  clusters.clear();
  for (const Line& line : lines) {
    const double theta = std::atan2(line.direction.y(), line.direction.x());
    const double w = line.length();
    for (double vote : {wrapPi(theta), wrapPi(theta + kPi / 2)}) {
      Cluster* best = nullptr;
      double best_diff = 0.0;
      for (Cluster& c : clusters) {
        const double d = std::abs(directionDiff(vote, c.angle));
        if (!best || d < best_diff) {
          best = &c;
          best_diff = d;
        }
      }
      if (!best || best_diff > cluster_angle) {
        clusters.push_back({vote, w});
        continue;
      }
      best->angle = wrapPi(best->angle + directionDiff(vote, best->angle) * w / (best->weight + w));
      best->weight += w;
    }
  }
  const auto heaviest =
      std::max_element(clusters.begin(), clusters.end(),
                       [](const Cluster& a, const Cluster& b) { return a.weight < b.weight; });
  if (heaviest == clusters.end()) return false;
  psi0 = heaviest->angle;
  return true;
}

const LineRun& LineGroup::runNear(double t) const {
  const LineRun* best = nullptr;
  double best_d = 0.0;
  for (const LineRun& run : runs) {
    const double d = std::max({0.0, run.t_min - t, t - run.t_max});
    if (!best || d < best_d) {
      best = &run;
      best_d = d;
    }
  }
  static const LineRun kNone{};
  return best ? *best : kNone;
}

namespace {

// The lines not on an excluded piece, and their indices into `lines`.
void usableLines(const std::vector<Line>& lines, const std::vector<int>& excluded_pieces,
                 std::vector<Line>& usable, std::vector<int>& usable_index) {
  usable.clear();
  usable_index.clear();
  for (int i = 0; i < static_cast<int>(lines.size()); ++i) {
    if (std::find(excluded_pieces.begin(), excluded_pieces.end(), lines[i].piece) !=
        excluded_pieces.end()) {
      continue;
    }
    usable.push_back(lines[i]);
    usable_index.push_back(i);
  }
}

// The lines parallel to `along` (perpendicular to `axis`, within the cluster angle) clustered by
// their offset along `axis` into collinear groups (members: indices into the frame's lines).
void groupCollinear(const std::vector<Line>& usable, const std::vector<int>& usable_index,
                    const Vec2& axis, const Vec2& along, const RecognitionParams& params,
                    std::vector<LineGroup>& groups) {
  const double min_cos = std::cos(params.direction_cluster);
  for (int i = 0; i < static_cast<int>(usable.size()); ++i) {
    const Line& line = usable[i];
    if (std::abs(line.direction.dot(along)) < min_cos) continue;
    const double t = line.midpoint().dot(axis);
    LineGroup* best = nullptr;
    double best_d = 0.0;
    for (LineGroup& g : groups) {
      const double d = std::abs(g.t - t);
      if (!best || d < best_d) {
        best = &g;
        best_d = d;
      }
    }
    const double w = line.length();
    if (!best || best_d > params.collinear_cluster) {
      groups.push_back({line, {}, t, w, {usable_index[i]}});
      continue;
    }
    best->t = (best->t * best->support + t * w) / (best->support + w);
    best->support += w;
    best->members.push_back(usable_index[i]);
  }
}

// One line over all points of the group's members, pointing along `along`, with its extent,
// point count and rms.
Line mergedLine(const Contours& contours, const std::vector<Line>& lines, const LineGroup& g,
                const Vec2& along) {
  LineAccumulator acc;
  for (int i : g.members) {
    const Piece& piece = contours.pieces[lines[i].piece];
    acc.add(contours.points.data() + piece.begin, piece.size());
  }
  Line merged;
  acc.finish(merged.centre, merged.direction);
  if (merged.direction.dot(along) < 0) merged.direction = -merged.direction;
  double sum_sq = 0.0;
  bool first = true;
  for (int i : g.members) {
    const Piece& piece = contours.pieces[lines[i].piece];
    for (int k = piece.begin; k < piece.end; ++k) {
      const Vec2& p = contours.points[k];
      const double t = merged.along(p);
      if (first) {
        merged.t_min = merged.t_max = t;
        first = false;
      }
      merged.t_min = std::min(merged.t_min, t);
      merged.t_max = std::max(merged.t_max, t);
      const double d = merged.signedDistance(p);
      sum_sq += d * d;
    }
  }
  merged.count = acc.count();
  merged.rms = std::sqrt(sum_sq / std::max(acc.count(), 1));
  merged.piece = -1;
  return merged;
}

// The members' extents along the merged line, chained into runs (parts closer than the run gap
// are one run), in order along the line.
void chainRuns(const Contours& contours, const std::vector<Line>& lines, const Line& merged,
               const RecognitionParams& params, LineGroup& g) {
  g.runs.clear();
  for (int i : g.members) {
    const Piece& piece = contours.pieces[lines[i].piece];
    LineRun run{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                piece.size()};
    for (int k = piece.begin; k < piece.end; ++k) {
      const double t = merged.along(contours.points[k]);
      run.t_min = std::min(run.t_min, t);
      run.t_max = std::max(run.t_max, t);
    }
    g.runs.push_back(run);
  }
  std::sort(g.runs.begin(), g.runs.end(),
            [](const LineRun& x, const LineRun& y) { return x.t_min < y.t_min; });
  std::size_t chained = 0;
  for (std::size_t r = 1; r < g.runs.size(); ++r) {
    LineRun& last = g.runs[chained];
    if (g.runs[r].t_min - last.t_max <= params.group_run_gap) {
      last.t_max = std::max(last.t_max, g.runs[r].t_max);
      last.count += g.runs[r].count;
    } else {
      g.runs[++chained] = g.runs[r];
    }
  }
  g.runs.resize(g.runs.empty() ? 0 : chained + 1);
}

}  // namespace

void buildLineStructure(const Contours& contours, const std::vector<Line>& lines,
                        const std::vector<int>& excluded_pieces, const RecognitionParams& params,
                        LineStructure& out) {
  out.clear();
  thread_local std::vector<Line> usable;
  thread_local std::vector<int> usable_index;
  usableLines(lines, excluded_pieces, usable, usable_index);
  if (!principalDirection(usable, params.direction_cluster, out.psi0)) return;
  out.found = true;
  out.axes[0] = Vec2(std::cos(out.psi0), std::sin(out.psi0));
  out.axes[1] = Vec2(-out.axes[0].y(), out.axes[0].x());

  for (int a = 0; a < 2; ++a) {
    const Vec2 axis = out.axes[a];
    const Vec2 along = out.axes[1 - a];
    auto& groups = out.groups[a];
    groupCollinear(usable, usable_index, axis, along, params, groups);
    for (LineGroup& g : groups) {
      const Line merged = mergedLine(contours, lines, g, along);
      chainRuns(contours, lines, merged, params, g);
      g.line = merged;
      g.t = merged.midpoint().dot(axis);
    }
    // The later stages look at pairs and triples of groups: a cluttered frame keeps only its
    // best supported groups, so their time stays bounded.
    if (static_cast<int>(groups.size()) > kMaxGroups) {
      std::nth_element(
          groups.begin(), groups.begin() + kMaxGroups, groups.end(),
          [](const LineGroup& x, const LineGroup& y) { return x.support > y.support; });
      groups.resize(kMaxGroups);
    }
    std::sort(groups.begin(), groups.end(),
              [](const LineGroup& x, const LineGroup& y) { return x.t < y.t; });
  }
}

}  // namespace fieldline::feature_recognition
