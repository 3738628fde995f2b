#include "services/feature_recognition/centre_circle.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>

namespace fieldline::feature_recognition {

CircleFit landauFit(const std::vector<Vec2>& points, Vec2 centre, int iterations) {
  CircleFit fit;
  fit.count = static_cast<int>(points.size());
  if (points.empty()) return fit;
  Vec2 mean = Vec2::Zero();
  for (const Vec2& p : points)
    mean += p;
  mean /= static_cast<double>(points.size());
  double radius = 0.0;
  for (int it = 0; it < iterations; ++it) {
    double sum_r = 0.0;
    Vec2 sum_unit = Vec2::Zero();
    for (const Vec2& p : points) {
      const Vec2 d = p - centre;
      const double r = d.norm();
      sum_r += r;
      if (r > 1e-12) sum_unit += d / r;
    }
    radius = sum_r / static_cast<double>(points.size());
    centre = mean - radius * sum_unit / static_cast<double>(points.size());
  }
  double sum_r = 0.0;
  for (const Vec2& p : points)
    sum_r += (p - centre).norm();
  radius = sum_r / static_cast<double>(points.size());
  double sum_sq = 0.0;
  for (const Vec2& p : points) {
    const double e = (p - centre).norm() - radius;
    sum_sq += e * e;
  }
  fit.centre = centre;
  fit.radius = radius;
  fit.rms = std::sqrt(sum_sq / static_cast<double>(points.size()));
  return fit;
}

double angularCoverage(const std::vector<Vec2>& points, const Vec2& centre) {
  constexpr int kSectors = 36;
  std::array<bool, kSectors> hit{};
  for (const Vec2& p : points) {
    const double a = std::atan2(p.y() - centre.y(), p.x() - centre.x()) + std::numbers::pi;
    const int s =
        std::clamp(static_cast<int>(a / (2 * std::numbers::pi) * kSectors), 0, kSectors - 1);
    hit[s] = true;
  }
  return static_cast<double>(std::count(hit.begin(), hit.end(), true)) * 2 * std::numbers::pi /
         kSectors;
}

namespace {

struct Cluster {
  Vec2 centre = Vec2::Zero();
  double weight = 0.0;
  std::vector<int> arcs;
};

// Clustering of the centres of the arcs of about the model's radius (seed: the first centre
// opens a cluster, each further centre joins the closest cluster within 0.6 r or opens a new
// one), each weighted by its arc's points.
void clusterArcCentres(const Classified& classified, double model_radius,
                       const RecognitionParams& params, std::vector<Cluster>& clusters) {
  clusters.clear();
  for (int i = 0; i < static_cast<int>(classified.arcs.size()); ++i) {
    const Arc& arc = classified.arcs[i];
    if (std::abs(arc.radius - model_radius) > params.arc_radius_tolerance * model_radius) continue;
    Cluster* best = nullptr;
    double best_distance = 0.0;
    for (Cluster& c : clusters) {
      const double d = (c.centre - arc.centre).norm();
      if (!best || d < best_distance) {
        best = &c;
        best_distance = d;
      }
    }
    const double weight = arc.count;
    if (!best || best_distance > params.circle_cluster_radius * arc.radius) {
      clusters.push_back({arc.centre, weight, {i}});
      continue;
    }
    best->centre = (best->centre * best->weight + arc.centre * weight) / (best->weight + weight);
    best->weight += weight;
    best->arcs.push_back(i);
  }
}

// Re-classification of straight pieces that lie on the circle about `m` of radius `r` (seed eq.
// 4.121-4.125): their points join `points`, their indices `pieces`.
void addStraightPiecesOnCircle(const Contours& contours, const Classified& classified,
                               const Vec2& m, double r, const RecognitionParams& params,
                               std::vector<Vec2>& points, std::vector<int>& pieces) {
  const double cos_limit = std::cos(params.reclassify_angle);
  for (int k : classified.straight_pieces) {
    const Piece& piece = contours.pieces[k];
    const Vec2* p = contours.points.data() + piece.begin;
    const Vec2 middle = p[piece.size() / 2];
    const Vec2 v = p[piece.size() - 1] - p[0];
    const double v_norm = v.norm();
    const Vec2 d = middle - m;
    if (d.norm() < 1e-9 || v_norm < 1e-9) continue;
    const Vec2 n = d.normalized();
    const Vec2 s = m + r * n;
    if ((middle - s).norm() > params.reclassify_distance * r) continue;
    const Vec2 t(-n.y(), n.x());
    if (std::abs(t.dot(v)) / v_norm < cos_limit) continue;
    points.insert(points.end(), p, p + piece.size());
    pieces.push_back(k);
  }
}

// The Landau fit from `centre`; points of other lines that were swept in (a line touching the
// circle) are then dropped from `points` and the fit repeated from the refined centre. None when
// too few points are left.
std::optional<CircleFit> fitWithoutOutliers(std::vector<Vec2>& points, const Vec2& centre,
                                            const RecognitionParams& params) {
  CircleFit fit = landauFit(points, centre, params.landau_iterations);
  const auto outliers = std::remove_if(points.begin(), points.end(), [&](const Vec2& p) {
    return std::abs((p - fit.centre).norm() - fit.radius) > params.circle_inlier_distance;
  });
  if (outliers != points.end()) {
    points.erase(outliers, points.end());
    if (static_cast<int>(points.size()) < params.circle_min_points) return std::nullopt;
    fit = landauFit(points, fit.centre, params.landau_iterations);
  }
  return fit;
}

}  // namespace

void findCircle(const Contours& contours, const Classified& classified, double model_radius,
                const RecognitionParams& params, CentreCircle& out) {
  out.clear();
  thread_local std::vector<Cluster> clusters;
  clusterArcCentres(classified, model_radius, params, clusters);
  const auto heaviest =
      std::max_element(clusters.begin(), clusters.end(),
                       [](const Cluster& a, const Cluster& b) { return a.weight < b.weight; });
  if (heaviest == clusters.end() || heaviest->weight < params.circle_min_points) return;

  thread_local std::vector<Vec2> points;
  points.clear();
  out.pieces.clear();
  for (int i : heaviest->arcs) {
    const Piece& piece = contours.pieces[classified.arcs[i].piece];
    points.insert(points.end(), contours.points.begin() + piece.begin,
                  contours.points.begin() + piece.end);
    out.pieces.push_back(classified.arcs[i].piece);
  }
  const Vec2 m = heaviest->centre;
  double r = 0.0;
  for (const Vec2& p : points)
    r += (p - m).norm();
  r /= static_cast<double>(points.size());
  addStraightPiecesOnCircle(contours, classified, m, r, params, points, out.pieces);

  const std::optional<CircleFit> fit = fitWithoutOutliers(points, m, params);
  if (!fit) return;
  if (std::abs(fit->radius - model_radius) > params.circle_radius_tolerance * model_radius) return;
  if (fit->rms > params.circle_max_rms) return;
  const double coverage = angularCoverage(points, fit->centre);
  if (coverage < params.circle_min_coverage) return;
  out.found = true;
  out.fit = *fit;
  out.coverage = coverage;
}

void findOrientationLine(const std::vector<Line>& lines, const RecognitionParams& params,
                         CentreCircle& circle) {
  if (!circle.found) return;
  const Line* best = nullptr;
  for (const Line& line : lines) {
    if (line.length() < params.min_orientation_line) continue;
    if (std::abs(line.signedDistance(circle.fit.centre)) > params.orientation_line_distance) {
      continue;
    }
    // The halfway line crosses the circle: its points reach inside it, not only past it.
    // It runs through the circle: on both sides of the centre (a line that merely starts near
    // the centre is something else).
    const double t_centre = line.along(circle.fit.centre);
    const double reach = params.orientation_line_reach * circle.fit.radius;
    if (t_centre - line.t_min < reach || line.t_max - t_centre < reach) continue;
    if (!best || line.length() > best->length()) best = &line;
  }
  if (!best) return;
  circle.oriented = true;
  circle.line_direction = best->direction;
  circle.line_rms = best->rms;
  circle.line_length = best->length();
  circle.line_count = best->count;
  circle.fit.centre -=
      best->signedDistance(circle.fit.centre) * Vec2(-best->direction.y(), best->direction.x());
}

}  // namespace fieldline::feature_recognition
