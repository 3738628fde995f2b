#include "tools/launch/parity.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace fieldline::launch {

std::vector<std::string> perRobotProcesses(const LaunchFile& file) {
  std::vector<std::string> names;
  for (const ProcessEntry& p : file.processes) {
    const bool for_robots = p.all_robots || std::any_of(p.robots.begin(), p.robots.end(),
                                                        [](int r) { return r != kSimRobot; });
    if (for_robots) names.push_back(p.name);
  }
  return names;
}

std::vector<std::string> parityProblems(const LaunchFile& team, const LaunchFile& robot) {
  const int robot_number = robot.defaults.robot > 0 ? robot.defaults.robot : 1;
  std::vector<std::string> problems;
  for (const std::string& name : perRobotProcesses(team)) {
    const auto& t = *std::find_if(team.processes.begin(), team.processes.end(),
                                  [&](const ProcessEntry& p) { return p.name == name; });
    const std::string where = fmt::format("{} ({}:{})", name, t.file, t.line);
    const auto r = std::find_if(robot.processes.begin(), robot.processes.end(),
                                [&](const ProcessEntry& p) { return p.name == name; });
    if (r == robot.processes.end()) {
      problems.push_back(fmt::format("{}: missing from {}", where, robot.path));
      continue;
    }
    const std::vector<int> robots = entryRobots(*r, robot.defaults, robot.defaults.robots);
    if (std::find(robots.begin(), robots.end(), robot_number) == robots.end()) {
      problems.push_back(
          fmt::format("{}: {} does not run it for its robot {}", where, robot.path, robot_number));
    }
    if (r->executable != t.executable) {
      problems.push_back(fmt::format("{}: {} runs {} instead of {}", where, robot.path,
                                     r->executable, t.executable));
    }
  }
  return problems;
}

}  // namespace fieldline::launch
