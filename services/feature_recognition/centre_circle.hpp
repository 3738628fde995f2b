// Stage 3 (seed 4.13, "Grouping Arcs and Detecting the Center Circle", "Refining the Initial
// Solution"): the centres of the arcs are clustered (cluster radius 0.6 r, weights = points); the
// heaviest cluster from 20 points is a circle; straight pieces that lie on it (centre within 0.5 r,
// direction within 25 degrees of the tangent) are re-classified as curved; Landau's iteration
// fits centre and radius to all those points. A line through the centre fixes the orientation and
// makes the circle the centre circle.
#pragma once

#include <vector>

#include "services/feature_recognition/classification.hpp"

namespace fieldline::feature_recognition {

struct CircleFit {
  Vec2 centre = Vec2::Zero();
  double radius = 0.0;
  // Rms distance of the points from the circle, m.
  double rms = 0.0;
  int count = 0;
};

// Landau's method: `iterations` times r = mean |p - c|, c = mean(p) - r * mean((p - c) / |p - c|).
CircleFit landauFit(const std::vector<Vec2>& points, Vec2 centre, int iterations);

// Angle covered by the points around `centre` (36 sectors of 10 degrees), rad.
double angularCoverage(const std::vector<Vec2>& points, const Vec2& centre);

struct CentreCircle {
  bool found = false;
  CircleFit fit;
  double coverage = 0.0;
  // Pieces (indices into Contours::pieces) whose points belong to the circle.
  std::vector<int> pieces;
  // Set by findOrientationLine: the line through the centre (the halfway line).
  bool oriented = false;
  Vec2 line_direction = Vec2::UnitX();
  double line_rms = 0.0;
  double line_length = 0.0;
  int line_count = 0;
  void clear() { *this = CentreCircle{}; }
};

// Finds the circle of the model's radius `model_radius` (m) among the arcs and straight pieces.
void findCircle(const Contours& contours, const Classified& classified, double model_radius,
                const RecognitionParams& params, CentreCircle& out);

// Looks for the longest line among `lines` that passes near the circle's centre; when found the
// circle is oriented and its centre is moved onto the line (the line is the more precise
// measurement across its direction).
void findOrientationLine(const std::vector<Line>& lines, const RecognitionParams& params,
                         CentreCircle& circle);

}  // namespace fieldline::feature_recognition
