#include "tools/launch/robot_clocks.hpp"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>

#include <fmt/format.h>

namespace fieldline::launch {

ClockError RobotClocks::of(int robot) const {
  const auto it = by_robot.find(robot);
  return it == by_robot.end() ? ClockError{} : it->second;
}

RobotClocks parseRobotClocks(const config::Node& root, Utime reference_us) {
  RobotClocks clocks;
  if (!root.has("robots")) return clocks;
  if (root.acceptEmpty("robots")) return clocks;
  for (const config::Node& entry : root.children("robots")) {
    const int id = entry.get<int>("id", 1, 99);
    ClockError error;
    error.reference_us = reference_us;
    if (auto clock = entry.childIf("clock")) {
      const double offset_s =
          clock->getOr<double>("offset_s", 0.0, -kMaxClockOffsetS, kMaxClockOffsetS);
      error.offset_us = static_cast<Utime>(std::llround(offset_s * 1e6));
      error.drift_ppm =
          clock->getOr<double>("drift_ppm", 0.0, -kMaxClockDriftPpm, kMaxClockDriftPpm);
      clock->rejectUnknownKeys();
    }
    entry.rejectUnknownKeys();
    if (!clocks.by_robot.emplace(id, error).second) {
      entry.fail("id", "robot " + std::to_string(id) + " is listed twice");
    }
  }
  return clocks;
}

Utime clockReferenceNow() {
  if (const char* text = std::getenv(kClockReferenceVariable); text && *text) {
    char* end = nullptr;
    const long long v = std::strtoll(text, &end, 10);
    if (end == text || *end != '\0' || v <= 0) {
      throw config::Error(std::string(kClockReferenceVariable) + "=" + text +
                          " is not a time in µs since the epoch");
    }
    return static_cast<Utime>(v);
  }
  return SystemClock().now();
}

std::map<int, Utime> parseClockControl(const std::string& text, const std::string& origin) {
  std::map<int, Utime> offsets;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream words(line);
    std::string robot_text, offset_text, extra;
    if (!(words >> robot_text)) continue;
    const auto fail = [&](const std::string& what) {
      throw config::Error(fmt::format("{}:{}: {} (expected `ROBOT OFFSET_US`, e.g. `1 2000000`)",
                                      origin, number, what));
    };
    words >> offset_text >> extra;
    if (offset_text.empty() || !extra.empty()) fail("'" + line + "' is not two numbers");
    int robot = 0;
    long long offset = 0;
    const auto whole = [](const std::string& w, auto& v) {
      const auto r = std::from_chars(w.data(), w.data() + w.size(), v);
      return r.ec == std::errc{} && r.ptr == w.data() + w.size();
    };
    if (!whole(robot_text, robot) || robot < 1 || robot > 99)
      fail("robot '" + robot_text + "' is not a robot number 1..99");
    if (!whole(offset_text, offset) ||
        std::fabs(static_cast<double>(offset)) > kMaxControlledOffsetS * 1e6)
      fail(fmt::format("offset '{}' is not a whole number of µs within +-{} s", offset_text,
                       kMaxControlledOffsetS));
    if (!offsets.emplace(robot, static_cast<Utime>(offset)).second)
      fail("robot " + robot_text + " is listed twice");
  }
  return offsets;
}

std::map<std::string, std::string> clockEnvironment(const ClockError& error) {
  if (error.offset_us == 0 && error.drift_ppm == 0.0) return {};
  return {{kClockOffsetVariable, std::to_string(error.offset_us)},
          {kClockDriftVariable, fmt::format("{}", error.drift_ppm)},
          {kClockReferenceVariable, std::to_string(error.reference_us)}};
}

}  // namespace fieldline::launch
