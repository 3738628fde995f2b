// Stage 1 of feature recognition (seed 4.13, "Smoothing the Lines", "Splitting the Lines"): the
// frame's point sequences are checked, smoothed (weights 0.25/0.5/0.25), their curvature measured
// from the points i-w and i+w, and they are split at curvature maxima and at jumps into pieces
// that are either straight or curved.
#pragma once

#include <string>
#include <vector>

#include "common/geometry/geometry.hpp"
#include "common/perception/line_points.hpp"
#include "services/feature_recognition/params.hpp"

namespace fieldline::feature_recognition {

using geometry::Vec2;

// A run of points [begin, end) in Contours::points.
struct Piece {
  int begin = 0;
  int end = 0;
  int size() const { return end - begin; }
};

struct Contours {
  // Smoothed points of the accepted sequences, back to back (robot frame, m).
  std::vector<Vec2> points;
  // Pieces after splitting, in sequence order.
  std::vector<Piece> pieces;
  void clear() {
    points.clear();
    pieces.clear();
  }
};

// What the input check refused. A frame is used as far as it is sound: a bad sequence is dropped,
// the rest is used; a frame with too many points is refused whole.
struct InputCheck {
  bool too_many_points = false;
  int sequences_used = 0;
  int out_of_range = 0;  // start or end outside the points, or end < start
  int overlapping = 0;   // shares points with an earlier sequence
  int non_finite = 0;    // contains a NaN or infinite coordinate
  int too_short = 0;     // fewer than min_sequence_points (not an error)

  int errors() const { return (too_many_points ? 1 : 0) + out_of_range + overlapping + non_finite; }
  // One line for a log or SERVICE_STATUS; empty when there was no error.
  std::string describe() const;
};

// One pass of the 0.25/0.5/0.25 filter over p[0..n); the end points are kept. out may not alias p.
void smoothSequence(const Vec2* p, int n, Vec2* out);

// The signed angle (rad, CCW positive) by which p[i]-p[i-w] turns into p[i+w]-p[i]; within w of
// an end the span shrinks to the points available, down to 2; 0 for the first and last 2 points.
void turningAngles(const Vec2* p, int n, int w, std::vector<double>& out);
// As turningAngles, but angles whose magnitude is at most `threshold` (< 1.5 rad) are left 0:
// all the split needs, without an atan2 for every straight stretch.
void turningAnglesAbove(const Vec2* p, int n, int w, double threshold, std::vector<double>& out);

// Indices of the maxima of |turn| inside the intervals where |turn| exceeds `threshold`; an
// interval opens only `min_separation` indices after the previous one closed (seed procedure 6).
void curvatureMaxima(const std::vector<double>& turn, double threshold, int min_separation,
                     std::vector<int>& out);

// Checks, smooths and splits the frame's sequences into `out`.
InputCheck prepareContours(const perception::LinePoints& in, const RecognitionParams& params,
                           Contours& out);

}  // namespace fieldline::feature_recognition
