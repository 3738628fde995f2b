#include "tools/launch/robot_clocks.hpp"

#include <cmath>
#include <cstdlib>
#include <set>

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

std::map<std::string, std::string> clockEnvironment(const ClockError& error) {
  if (error.offset_us == 0 && error.drift_ppm == 0.0) return {};
  return {{kClockOffsetVariable, std::to_string(error.offset_us)},
          {kClockDriftVariable, fmt::format("{}", error.drift_ppm)},
          {kClockReferenceVariable, std::to_string(error.reference_us)}};
}

}  // namespace fieldline::launch
