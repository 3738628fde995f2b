#include "services/fusion/points_csv.hpp"

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace fieldline::fusion {
namespace {

bool blank(const std::string& line) {
  return line.find_first_not_of(" \t\r") == std::string::npos;
}

// The field as one number (surrounding spaces allowed); false for anything else.
bool parseNumber(const std::string& field, double& value) {
  const char* begin = field.c_str();
  char* end = nullptr;
  errno = 0;
  value = std::strtod(begin, &end);
  if (end == begin || errno == ERANGE) return false;
  while (*end == ' ' || *end == '\t' || *end == '\r')
    ++end;
  return *end == '\0';
}

}  // namespace

perception::LinePoints readLinePointsCsv(std::istream& in, const std::string& name,
                                         std::size_t max_points) {
  perception::LinePoints out;
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
    if (blank(line)) {
      closeSequence();
      continue;
    }
    const std::size_t first = line.find_first_not_of(" \t");
    if (line[first] == '#') continue;
    const std::size_t comma = line.find(',');
    double x = 0, y = 0;
    if (comma == std::string::npos || line.find(',', comma + 1) != std::string::npos ||
        !parseNumber(line.substr(0, comma), x) || !parseNumber(line.substr(comma + 1), y)) {
      throw std::invalid_argument(name + ":" + std::to_string(number) +
                                  ": expected \"x,y\" (two numbers, metres), got \"" + line + "\"");
    }
    if (out.points.size() >= max_points) {
      throw std::invalid_argument(name + ":" + std::to_string(number) + ": more than " +
                                  std::to_string(max_points) + " points");
    }
    perception::LinePoint p;
    p.x = static_cast<float>(x);
    p.y = static_cast<float>(y);
    out.points.push_back(p);
  }
  closeSequence();
  return out;
}

perception::LinePoints readLinePointsCsvFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open");
  return readLinePointsCsv(in, path);
}

}  // namespace fieldline::fusion
