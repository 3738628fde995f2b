#include "services/feature_recognition/classification.hpp"

#include <cmath>

namespace fieldline::feature_recognition {

void LineAccumulator::add(const Vec2& p) {
  ++n_;
  sx_ += p.x();
  sy_ += p.y();
  sxx_ += p.x() * p.x();
  sxy_ += p.x() * p.y();
  syy_ += p.y() * p.y();
}

void LineAccumulator::finish(Vec2& centre, Vec2& direction) const {
  const double inv = 1.0 / n_;
  centre = Vec2(sx_ * inv, sy_ * inv);
  const double cxx = sxx_ * inv - centre.x() * centre.x();
  const double cxy = sxy_ * inv - centre.x() * centre.y();
  const double cyy = syy_ * inv - centre.y() * centre.y();
  // Major axis of the 2x2 covariance.
  const double angle = 0.5 * std::atan2(2.0 * cxy, cxx - cyy);
  direction = Vec2(std::cos(angle), std::sin(angle));
}

Line fitLine(const Vec2* p, int n) {
  LineAccumulator acc;
  acc.add(p, n);
  Line line;
  acc.finish(line.centre, line.direction);
  // Direction from the first point toward the last, so that start() is near p[0].
  if ((p[n - 1] - p[0]).dot(line.direction) < 0) line.direction = -line.direction;
  double sum_sq = 0.0;
  line.t_min = line.t_max = line.along(p[0]);
  for (int i = 0; i < n; ++i) {
    const double t = line.along(p[i]);
    line.t_min = std::min(line.t_min, t);
    line.t_max = std::max(line.t_max, t);
    const double d = line.signedDistance(p[i]);
    sum_sq += d * d;
  }
  line.rms = std::sqrt(sum_sq / n);
  line.count = n;
  return line;
}

double pieceTurn(const Vec2* p, int n) {
  const Vec2 a = p[n / 2] - p[0];
  const Vec2 b = p[n - 1] - p[n / 2];
  return std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
}

bool fitArc(const Vec2* p, int n, Arc& out) {
  // Intersection of the perpendicular bisectors of first-middle and middle-last.
  const Vec2 a = p[0], b = p[n / 2], c = p[n - 1];
  const double d =
      2.0 * (a.x() * (b.y() - c.y()) + b.x() * (c.y() - a.y()) + c.x() * (a.y() - b.y()));
  const double scale = std::max((c - a).squaredNorm(), 1e-12);
  if (std::abs(d) < 1e-9 * scale) return false;
  const double a2 = a.squaredNorm(), b2 = b.squaredNorm(), c2 = c.squaredNorm();
  const Vec2 centre((a2 * (b.y() - c.y()) + b2 * (c.y() - a.y()) + c2 * (a.y() - b.y())) / d,
                    (a2 * (c.x() - b.x()) + b2 * (a.x() - c.x()) + c2 * (b.x() - a.x())) / d);
  // Mean and spread of the distances in one loop (seed eq. 4.119-4.120).
  double sum = 0.0, sum_sq = 0.0;
  for (int i = 0; i < n; ++i) {
    const double r = (p[i] - centre).norm();
    sum += r;
    sum_sq += r * r;
  }
  const double mean = sum / n;
  const double variance = std::max(sum_sq / n - mean * mean, 0.0);
  out.centre = centre;
  out.radius = mean;
  out.relative_deviation = mean > 0 ? std::sqrt(variance) / mean : 1e9;
  out.count = n;
  return std::isfinite(mean);
}

namespace {

// Index in [1, n-1) of the point furthest from the chord p[0]-p[n-1].
int furthestFromChord(const Vec2* p, int n) {
  const Vec2 chord = p[n - 1] - p[0];
  const double length = std::max(chord.norm(), 1e-9);
  int best = n / 2;
  double best_distance = -1.0;
  for (int i = 1; i + 1 < n; ++i) {
    const Vec2 d = p[i] - p[0];
    const double distance = std::abs(chord.x() * d.y() - chord.y() * d.x()) / length;
    if (distance > best_distance) {
      best_distance = distance;
      best = i;
    }
  }
  return best;
}

bool looksStraight(const Vec2* p, int n, const RecognitionParams& params) {
  if (n < 3) return false;
  if (std::abs(pieceTurn(p, n)) > params.curved_angle / 2) return false;
  const Line line = fitLine(p, n);
  return line.rms <= params.max_line_rms && line.length() >= params.min_line_length;
}

}  // namespace

void classifyPieces(Contours& contours, const RecognitionParams& params, Classified& out) {
  out.clear();
  // Pieces appended while splitting are classified in the same loop.
  for (int k = 0; k < static_cast<int>(contours.pieces.size()); ++k) {
    const Piece piece = contours.pieces[k];
    const Vec2* p = contours.points.data() + piece.begin;
    const int n = piece.size();
    if (n < 3) continue;
    if (std::abs(pieceTurn(p, n)) > params.curved_angle) {
      // A corner the curvature split missed (too near an end, or rounded): the piece is two
      // straight legs meeting at its point furthest from the chord, not an arc.
      const int split = furthestFromChord(p, n);
      const bool first_straight = looksStraight(p, split, params);
      const bool second_straight = looksStraight(p + split + 1, n - split - 1, params);
      if (first_straight || second_straight) {
        const Vec2 a = p[split] - p[0], b = p[n - 1] - p[split];
        const double turn = std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)));
        if (turn > params.corner_split_angle) {
          if (split >= params.min_split_points) {
            contours.pieces.push_back({piece.begin, piece.begin + split});
          }
          if (n - split - 1 >= params.min_split_points) {
            contours.pieces.push_back({piece.begin + split + 1, piece.end});
          }
          continue;
        }
      }
      Arc arc;
      if (fitArc(p, n, arc) && arc.relative_deviation <= params.max_arc_relative_deviation) {
        arc.piece = k;
        out.arcs.push_back(arc);
        continue;
      }
      // Not an arc either: a noisy straight piece whose ends happened to bend (far away the
      // points scatter more). It is straight if a line fits it.
    }
    Line line = fitLine(p, n);
    if (line.rms > params.max_line_rms && n >= 2 * params.min_split_points) {
      // Corners the curvature missed (sparse far points, several lines in one sequence): split
      // at the point furthest from the chord, as a polyline simplification would.
      const int split = furthestFromChord(p, n);
      contours.pieces.push_back({piece.begin, piece.begin + split});
      contours.pieces.push_back({piece.begin + split + 1, piece.end});
      continue;
    }
    out.straight_pieces.push_back(k);
    line.piece = k;
    if (line.rms <= params.max_line_rms && line.length() >= params.min_line_length) {
      out.lines.push_back(line);
    }
  }
}

}  // namespace fieldline::feature_recognition
