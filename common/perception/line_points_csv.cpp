#include "common/perception/line_points_csv.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <istream>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>

namespace fieldline::perception {
namespace {

bool isSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

// Reads one number at `p` (leading spaces skipped) into `value`; returns its text, or an empty
// string when there is no number. Overflow reads as an infinity (refused as not finite, with the
// text in the message).
std::string readNumber(const char*& p, double& value) {
  while (isSpace(*p))
    ++p;
  char* end = nullptr;
  value = std::strtod(p, &end);
  if (end == p) return {};
  std::string text(p, static_cast<const char*>(end));
  p = end;
  return text;
}

// The separator between x and y: one comma with optional spaces around it, or spaces alone.
bool skipSeparator(const char*& p) {
  const char* start = p;
  while (isSpace(*p))
    ++p;
  if (*p == ',') {
    ++p;
    return true;
  }
  return p != start;
}

}  // namespace

LinePoints readLinePointsCsv(std::istream& in, const std::string& name, std::size_t max_points,
                             double scale) {
  LinePoints out;
  std::string line;
  int number = 0;
  int sequence_start = 0;
  auto closeSequence = [&] {
    const int end = static_cast<int>(out.points.size());
    if (end > sequence_start) out.sequences.emplace_back(sequence_start, end);
    sequence_start = end;
  };
  while (std::getline(in, line)) {
    ++number;
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) {
      closeSequence();
      continue;
    }
    if (line[first] == '#') continue;
    const auto where = [&] { return name + ":" + std::to_string(number) + ": "; };
    const char* p = line.c_str() + first;
    double x = 0, y = 0;
    const std::string x_text = readNumber(p, x);
    const bool separated = !x_text.empty() && skipSeparator(p);
    const std::string y_text = separated ? readNumber(p, y) : std::string();
    while (isSpace(*p))
      ++p;
    if (y_text.empty() || *p != '\0') {
      throw std::invalid_argument(where() + "expected \"x,y\" (two numbers, metres), got \"" +
                                  line + "\"");
    }
    for (const auto& [axis, value, text] :
         {std::tuple{"x", x, x_text}, std::tuple{"y", y, y_text}}) {
      if (!std::isfinite(value)) {
        throw std::invalid_argument(where() + axis + " = " + text +
                                    " is not a finite number (a line point is a position in the "
                                    "robot frame)");
      }
      if (std::abs(value * scale) > kMaxLinePointCoordinateM) {
        std::ostringstream metres;
        metres << value * scale;
        throw std::invalid_argument(
            where() + axis + " = " + text + " is out of range: " + metres.str() +
            " m from the robot (more than " +
            std::to_string(static_cast<int>(kMaxLinePointCoordinateM)) + " m: wrong units?)");
      }
    }
    if (out.points.size() >= max_points) {
      throw std::invalid_argument(where() + "more than " + std::to_string(max_points) + " points");
    }
    LinePoint point;
    point.x = static_cast<float>(x * scale);
    point.y = static_cast<float>(y * scale);
    out.points.push_back(point);
  }
  closeSequence();
  return out;
}

LinePoints readLinePointsCsvFile(const std::string& path, double scale) {
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) {
    throw std::invalid_argument(path + ": cannot open (no such file)");
  }
  // An ifstream opens a directory without complaint and reads nothing from it.
  if (std::filesystem::is_directory(status)) {
    throw std::invalid_argument(path + ": is a directory, not a CSV file of line points");
  }
  if (!std::filesystem::is_regular_file(status)) {
    throw std::invalid_argument(path + ": not a regular file");
  }
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open");
  LinePoints points = readLinePointsCsv(in, path, 1000000, scale);
  if (in.bad()) throw std::invalid_argument(path + ": read error");
  if (points.points.empty()) throw std::invalid_argument(path + ": no line points in the file");
  return points;
}

void writeLinePointsCsv(std::ostream& out, const LinePoints& points) {
  out << "# x,y in the robot frame (m, x forward, y left); a blank line ends a sequence\n";
  for (const auto& [start, end] : points.sequences) {
    for (int i = start; i < end; ++i)
      out << points.points[i].x << ',' << points.points[i].y << '\n';
    out << '\n';
  }
}

}  // namespace fieldline::perception
