// Line points as text, for people with real data and for recorded test sets: one point per line,
// "x,y" (or "x y") in the robot frame (x forward, y left, m); a blank line ends a sequence; lines
// starting with '#' are comments. Plain file I/O, no bus.
#pragma once

#include <iosfwd>
#include <string>

#include "common/perception/line_points.hpp"

namespace fieldline::feature_recognition {

// Coordinates farther than this are no line point a camera saw: refused as out of range [m].
inline constexpr double kMaxCoordinateM = 100.0;

// Throws std::runtime_error naming the line for text that is not two finite numbers within
// kMaxCoordinateM (NaN, inf and 1e308 each say what is wrong), and for a directory or an unreadable
// file.
perception::LinePoints readPointsCsv(std::istream& in, const std::string& name = "input");
perception::LinePoints readPointsCsvFile(const std::string& path);
void writePointsCsv(std::ostream& out, const perception::LinePoints& points);

}  // namespace fieldline::feature_recognition
