#include "services/fusion/points_csv.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <tuple>

namespace fieldline::fusion {
namespace {

bool blank(const std::string& line) {
  return line.find_first_not_of(" \t\r") == std::string::npos;
}

// The field as one number (surrounding spaces allowed); false for anything else. Overflow
// parses to an infinity (refused as not finite by the caller, with the number in the message).
bool parseNumber(const std::string& field, double& value) {
  const char* begin = field.c_str();
  char* end = nullptr;
  value = std::strtod(begin, &end);
  if (end == begin) return false;
  while (*end == ' ' || *end == '\t' || *end == '\r')
    ++end;
  return *end == '\0';
}

std::string trimmed(const std::string& text) {
  const std::size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

}  // namespace

perception::LinePoints readLinePointsCsv(std::istream& in, const std::string& name,
                                         std::size_t max_points, double scale) {
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
    const auto where = [&] { return name + ":" + std::to_string(number) + ": "; };
    for (const auto& [axis, value, text] :
         {std::tuple{"x", x, line.substr(0, comma)}, std::tuple{"y", y, line.substr(comma + 1)}}) {
      if (!std::isfinite(value)) {
        throw std::invalid_argument(where() + axis + " = " + trimmed(text) +
                                    " is not a finite number (a line point is a position in the "
                                    "robot frame)");
      }
      if (std::abs(value * scale) > kMaxPointCoordinateM) {
        throw std::invalid_argument(
            where() + axis + " = " + trimmed(text) + " is " + std::to_string(value * scale) +
            " m from the robot (more than " +
            std::to_string(static_cast<int>(kMaxPointCoordinateM)) + " m: wrong units?)");
      }
    }
    if (out.points.size() >= max_points) {
      throw std::invalid_argument(name + ":" + std::to_string(number) + ": more than " +
                                  std::to_string(max_points) + " points");
    }
    perception::LinePoint p;
    p.x = static_cast<float>(x * scale);
    p.y = static_cast<float>(y * scale);
    out.points.push_back(p);
  }
  closeSequence();
  return out;
}

perception::LinePoints readLinePointsCsvFile(const std::string& path, double scale) {
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) {
    throw std::invalid_argument(path + ": cannot open (no such file)");
  }
  if (std::filesystem::is_directory(status)) {
    throw std::invalid_argument(path + ": is a directory, not a CSV file of line points");
  }
  if (!std::filesystem::is_regular_file(status)) {
    throw std::invalid_argument(path + ": not a regular file");
  }
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open");
  perception::LinePoints points = readLinePointsCsv(in, path, 1000000, scale);
  if (in.bad()) throw std::invalid_argument(path + ": read error");
  if (points.points.empty()) throw std::invalid_argument(path + ": no line points in the file");
  return points;
}

}  // namespace fieldline::fusion
