// line_contours_t (VISION_LINES) <-> perception::LinePoints.
#pragma once

#include <fieldline/line_contours_t.hpp>

#include "common/perception/line_points.hpp"

namespace fieldline::msg {

// Points and sequences of a validated message (bus/validate.hpp has checked sizes, finiteness
// and that every sequence lies inside the points).
void fromMessage(const line_contours_t& m, perception::LinePoints& out);
perception::LinePoints toLinePoints(const line_contours_t& m);

// Writes the points and sequences into `m` (header and tracker statistics untouched).
void toMessage(const perception::LinePoints& lines, line_contours_t& m);

}  // namespace fieldline::msg
