#include "services/feature_recognition/points_csv.hpp"

#include <charconv>
#include <fstream>
#include <istream>
#include <ostream>
#include <stdexcept>

namespace fieldline::feature_recognition {

namespace {

bool parseNumber(const char*& p, const char* end, float& out) {
  while (p < end && (*p == ' ' || *p == '\t' || *p == ','))
    ++p;
  const auto [next, ec] = std::from_chars(p, end, out);
  if (ec != std::errc()) return false;
  p = next;
  return true;
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
    if (!parseNumber(p, end, point.x) || !parseNumber(p, end, point.y)) {
      throw std::runtime_error(name + ":" + std::to_string(line_number) +
                               ": expected two numbers x,y (m), got '" + line + "'");
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
  std::ifstream file(path);
  if (!file) throw std::runtime_error(path + ": cannot open");
  return readPointsCsv(file, path);
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
