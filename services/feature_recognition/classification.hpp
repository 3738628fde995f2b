// Stage 2 (seed 4.13, "Classification", "Constructing Arcs and straight lines"): each piece is
// straight or curved by the angle between first->middle and middle->last; curved pieces become
// circular arcs through their first, middle and last point and are kept when the points' relative
// radius deviation is small; straight pieces become lines fitted to all their points.
#pragma once

#include <vector>

#include "services/feature_recognition/contour_preparation.hpp"

namespace fieldline::feature_recognition {

// A straight line fitted to points (total least squares).
struct Line {
  // Unit direction and the points' extent along it: the ends are
  // centre + direction * t_min and centre + direction * t_max.
  Vec2 centre = Vec2::Zero();
  Vec2 direction = Vec2::UnitX();
  double t_min = 0.0;
  double t_max = 0.0;
  // Rms distance of the points from the line, m, and their number.
  double rms = 0.0;
  int count = 0;
  // The piece it came from (index into Contours::pieces), -1 for a merged group.
  int piece = -1;

  double length() const { return t_max - t_min; }
  Vec2 start() const { return centre + t_min * direction; }
  Vec2 end() const { return centre + t_max * direction; }
  Vec2 midpoint() const { return centre + 0.5 * (t_min + t_max) * direction; }
  // Signed distance of p from the line (positive to the left of the direction).
  double signedDistance(const Vec2& p) const {
    const Vec2 d = p - centre;
    return direction.x() * d.y() - direction.y() * d.x();
  }
  double along(const Vec2& p) const { return (p - centre).dot(direction); }
};

struct Arc {
  Vec2 centre = Vec2::Zero();
  double radius = 0.0;
  double relative_deviation = 0.0;
  int piece = -1;
  int count = 0;
};

struct Classified {
  std::vector<Line> lines;  // straight pieces that fit a line
  std::vector<Arc> arcs;    // curved pieces that fit an arc
  // Straight pieces by index into Contours::pieces, including those whose fit was poor (the
  // circle stage may re-classify them).
  std::vector<int> straight_pieces;
  void clear() {
    lines.clear();
    arcs.clear();
    straight_pieces.clear();
  }
};

// Least-squares line through p[0..n) (n >= 2).
Line fitLine(const Vec2* p, int n);
// Accumulates points into a line fit; finish() needs at least two distinct points.
class LineAccumulator {
 public:
  void add(const Vec2& p);
  void add(const Vec2* p, int n) {
    for (int i = 0; i < n; ++i)
      add(p[i]);
  }
  int count() const { return n_; }
  // The line's direction and centre; the extent and rms need the points again (see fitLine).
  void finish(Vec2& centre, Vec2& direction) const;

 private:
  int n_ = 0;
  double sx_ = 0, sy_ = 0, sxx_ = 0, sxy_ = 0, syy_ = 0;
};

// The turn from first->middle to middle->last of the piece, rad (the classification measure).
double pieceTurn(const Vec2* p, int n);
// The arc through first, middle and last point; radius = mean distance of all points from the
// centre, relative_deviation = their standard deviation / mean. False for collinear points.
bool fitArc(const Vec2* p, int n, Arc& out);

// Classifies every piece. A curved piece that is two straight legs meeting at a corner is split
// there (its halves are appended to contours.pieces and classified in turn).
void classifyPieces(Contours& contours, const RecognitionParams& params, Classified& out);

}  // namespace fieldline::feature_recognition
