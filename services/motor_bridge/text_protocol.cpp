#include "services/motor_bridge/text_protocol.hpp"

#include <charconv>
#include <cmath>
#include <limits>
#include <vector>

#include <fmt/format.h>

namespace fieldline::motor_bridge::text {
namespace {

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t'))
      ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t')
      ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

template <typename T>
bool parseInteger(std::string_view word, T& out) {
  const auto* end = word.data() + word.size();
  const auto [ptr, ec] = std::from_chars(word.data(), end, out);
  return ec == std::errc{} && ptr == end;
}

bool parseReal(std::string_view word, double& out) {
  const auto* end = word.data() + word.size();
  const auto [ptr, ec] = std::from_chars(word.data(), end, out);
  return ec == std::errc{} && ptr == end && std::isfinite(out);
}

LineError error(std::string what, std::string_view line) {
  return {fmt::format("{}: '{}'", what, line)};
}

}  // namespace

Line parseLine(std::string_view line) {
  const auto w = words(line);
  if (w.empty()) return error("empty line", line);
  if (w[0].starts_with('#')) return Comment{};
  if (w[0] == "O") {
    if (w.size() < 2 + 1 || w.size() > 2 + kMaxWheels) {
      return error(fmt::format("O needs a time and 1 to {} tick counts", kMaxWheels), line);
    }
    TickLine out;
    if (!parseInteger(w[1], out.controller_time_us) || out.controller_time_us < 0) {
      return error("O: time is not a non-negative integer (us)", line);
    }
    for (std::size_t i = 2; i < w.size(); ++i) {
      std::int32_t ticks = 0;
      if (!parseInteger(w[i], ticks)) {
        return error(fmt::format("O: tick count {} is not an int32", i - 2), line);
      }
      out.ticks.push_back(ticks);
    }
    return out;
  }
  if (w[0] == "S") {
    if (w.size() != 5) return error("S needs a time and vx vy omega", line);
    VelocityLine out;
    if (!parseInteger(w[1], out.controller_time_us) || out.controller_time_us < 0) {
      return error("S: time is not a non-negative integer (us)", line);
    }
    if (!parseReal(w[2], out.vx) || !parseReal(w[3], out.vy) || !parseReal(w[4], out.omega)) {
      return error("S: vx vy omega must be finite numbers", line);
    }
    return out;
  }
  return error("unknown line type", line);
}

std::string formatCommand(double vx, double vy, double omega) {
  return fmt::format("V {:.4f} {:.4f} {:.4f}\n", vx, vy, omega);
}

}  // namespace fieldline::motor_bridge::text
