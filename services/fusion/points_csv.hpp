// Line points in a CSV text (the input of fieldline-localize, and a way to feed recorded points
// to layer 2): one point per line as "x,y" in the robot frame (m, x forward, y left), a blank
// line between sequences, '#' starts a comment line.
#pragma once

#include <istream>
#include <string>

#include "common/perception/line_points.hpp"

namespace fieldline::fusion {

// Reads every point; throws std::invalid_argument "NAME:LINE: reason" for a line that is not
// two numbers, and for more than `max_points` points. "nan" and "inf" parse (layer 2 skips them).
perception::LinePoints readLinePointsCsv(std::istream& in, const std::string& name,
                                         std::size_t max_points = 1000000);
// The same from a file; throws std::invalid_argument when it cannot be opened.
perception::LinePoints readLinePointsCsvFile(const std::string& path);

}  // namespace fieldline::fusion
