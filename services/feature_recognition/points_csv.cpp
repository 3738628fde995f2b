#include "services/feature_recognition/points_csv.hpp"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <istream>
#include <ostream>
#include <stdexcept>

#include <fmt/format.h>

namespace fieldline::feature_recognition {

namespace {

// Reads one coordinate; an empty string when it is fine, else what is wrong with it. Parsed as a
// double first, so 1e308 is "out of range" rather than "not a number".
std::string parseNumber(const char*& p, const char* end, float& out) {
  while (p < end && (*p == ' ' || *p == '\t' || *p == ','))
    ++p;
  double value = 0.0;
  const auto [next, ec] = std::from_chars(p, end, value);
  const std::string text(p, ec == std::errc::invalid_argument ? p : next);
  if (ec == std::errc::invalid_argument) return "expected two numbers x,y (m)";
  if (ec == std::errc::result_out_of_range || std::abs(value) > kMaxCoordinateM) {
    return fmt::format("{} m is out of range (a line point is within {:.0f} m of the robot)", text,
                       kMaxCoordinateM);
  }
  if (!std::isfinite(value)) return "'" + text + "' is not a finite number";
  p = next;
  out = static_cast<float>(value);
  return {};
}

}  // namespace

perception::LinePoints readPointsCsv(std::istream& in, const std::string& name) {
  perception::LinePoints out;
  std::string line;
  int line_number = 0;
  int sequence_start = 0;
  auto close = [&] {
    const int end = static_cast<int>(out.points.size());
    if (end > sequence_start) out.sequences.emplace_back(sequence_start, end);
    sequence_start = end;
  };
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos) {
      close();
      continue;
    }
    if (line[first] == '#') continue;
    const char* p = line.data() + first;
    const char* end = line.data() + line.size();
    perception::LinePoint point;
    std::string problem = parseNumber(p, end, point.x);
    if (problem.empty()) problem = parseNumber(p, end, point.y);
    if (!problem.empty()) {
      throw std::runtime_error(name + ":" + std::to_string(line_number) + ": " + problem +
                               ", got '" + line + "'");
    }
    while (p < end && (*p == ' ' || *p == '\t'))
      ++p;
    if (p != end) {
      throw std::runtime_error(name + ":" + std::to_string(line_number) +
                               ": unexpected text after x,y: '" + line + "'");
    }
    out.points.push_back(point);
  }
  close();
  return out;
}

perception::LinePoints readPointsCsvFile(const std::string& path) {
  std::error_code ec;
  // An ifstream opens a directory without complaint and reads nothing from it.
  if (std::filesystem::is_directory(path, ec)) {
    throw std::runtime_error(path + ": is a directory, not a file of points");
  }
  std::ifstream file(path);
  if (!file) throw std::runtime_error(path + ": cannot open");
  auto points = readPointsCsv(file, path);
  if (file.bad()) throw std::runtime_error(path + ": read error");
  return points;
}

void writePointsCsv(std::ostream& out, const perception::LinePoints& points) {
  out << "# x,y in the robot frame (m, x forward, y left); a blank line ends a sequence\n";
  for (const auto& [start, end] : points.sequences) {
    for (int i = start; i < end; ++i)
      out << points.points[i].x << ',' << points.points[i].y << '\n';
    out << '\n';
  }
}

}  // namespace fieldline::feature_recognition
