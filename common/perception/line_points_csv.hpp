// Line points as text, the one reader and writer of the format (fieldline-localize,
// fieldline-features, fieldline-eval-features --dump, fieldline-tracking-png --csv): one point per
// line, "x,y" or "x y" in the robot frame (m, x forward, y left); a blank line ends a sequence;
// a line starting with '#' is a comment. Plain file I/O, no bus.
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>

#include "common/perception/line_points.hpp"

namespace fieldline::perception {

// A coordinate farther than this from the robot is no line point a camera saw (a unit mistake,
// millimetres read as metres), m.
inline constexpr double kMaxLinePointCoordinateM = 100.0;

// Reads every point. Throws std::invalid_argument "NAME:LINE: reason" for a line that is not two
// numbers, for a coordinate that is not finite ("nan", "inf", 1e999) or farther than
// kMaxLinePointCoordinateM after scaling, and for more than `max_points` points. `scale`
// multiplies every coordinate (0.001 reads millimetres).
LinePoints readLinePointsCsv(std::istream& in, const std::string& name = "input",
                             std::size_t max_points = 1000000, double scale = 1.0);
// The same from a file; throws std::invalid_argument when it does not exist, is not a regular
// file (a directory, a device), cannot be read or holds no point.
LinePoints readLinePointsCsvFile(const std::string& path, double scale = 1.0);
// Writes `points` in the format read above (a comment line first, a blank line after each
// sequence).
void writeLinePointsCsv(std::ostream& out, const LinePoints& points);

}  // namespace fieldline::perception
