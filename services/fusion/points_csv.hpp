// Line points in a CSV text (the input of fieldline-localize, and a way to feed recorded points
// to layer 2): one point per line as "x,y" in the robot frame (m, x forward, y left), a blank
// line between sequences, '#' starts a comment line.
#pragma once

#include <istream>
#include <string>

#include "common/perception/line_points.hpp"

namespace fieldline::fusion {

// A coordinate further than this from the robot is no line point a camera saw, m.
inline constexpr double kMaxPointCoordinateM = 1000.0;

// Reads every point; throws std::invalid_argument "NAME:LINE: reason" for a line that is not two
// numbers, for a coordinate that is not finite ("nan", "inf", 1e999) or further than
// kMaxPointCoordinateM (1e308: a unit mistake, not a point), and for more than `max_points` points.
// `scale` multiplies every coordinate (0.001 reads millimetres).
perception::LinePoints readLinePointsCsv(std::istream& in, const std::string& name,
                                         std::size_t max_points = 1000000, double scale = 1.0);
// The same from a file; throws std::invalid_argument when it is not a readable regular file (a
// directory, a device) or holds no point.
perception::LinePoints readLinePointsCsvFile(const std::string& path, double scale = 1.0);

}  // namespace fieldline::fusion
