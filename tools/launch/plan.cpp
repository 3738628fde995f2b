#include "tools/launch/plan.hpp"

#include <algorithm>
#include <filesystem>
#include <set>

#include <unistd.h>

namespace fieldline::launch {
namespace {

bool isExecutableFile(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec) && ::access(path.c_str(), X_OK) == 0;
}

std::string shellQuote(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789_-./:=,+@%") == std::string::npos) {
    return word;
  }
  std::string quoted = "'";
  for (char c : word) {
    if (c == '\'') {
      quoted += "'\\''";
    } else {
      quoted += c;
    }
  }
  return quoted + "'";
}

}  // namespace

std::string LaunchInstance::label() const {
  return robotLabel(robot) + " " + name;
}

std::string robotLabel(int robot) {
  return robot == kSimRobot ? "sim" : "r" + std::to_string(robot);
}

std::string substituteRobot(const std::string& arg, int robot) {
  static const std::string kPlaceholder = "{robot}";
  std::string out;
  std::size_t from = 0;
  for (std::size_t at = arg.find(kPlaceholder); at != std::string::npos;
       at = arg.find(kPlaceholder, from)) {
    out.append(arg, from, at - from);
    out += std::to_string(robot);
    from = at + kPlaceholder.size();
  }
  out.append(arg, from, std::string::npos);
  return out;
}

std::vector<std::string> buildCommandLine(const ProcessEntry& entry, int robot,
                                          const bus::BusAddress& address,
                                          const std::string& executable_path) {
  const std::string sim_url = bus::simBusUrl(address);
  std::vector<std::string> argv{executable_path.empty() ? entry.executable : executable_path,
                                "--robot",
                                std::to_string(robot),
                                "--bus-url",
                                robot == kSimRobot ? sim_url : bus::robotBusUrl(robot, address),
                                "--sim-bus-url",
                                sim_url};
  for (const std::string& arg : entry.args)
    argv.push_back(substituteRobot(arg, robot));
  return argv;
}

std::string findExecutable(const std::string& executable, const std::string& bin_dir,
                           const char* search_path) {
  if (executable.find('/') != std::string::npos) {
    return isExecutableFile(executable) ? executable : "";
  }
  if (!bin_dir.empty()) {
    const auto candidate = std::filesystem::path(bin_dir) / executable;
    if (isExecutableFile(candidate)) return candidate.string();
  }
  if (search_path == nullptr) return "";
  const std::string dirs(search_path);
  std::size_t from = 0;
  while (from <= dirs.size()) {
    std::size_t end = dirs.find(':', from);
    if (end == std::string::npos) end = dirs.size();
    const std::string dir = dirs.substr(from, end - from);
    if (!dir.empty()) {
      const auto candidate = std::filesystem::path(dir) / executable;
      if (isExecutableFile(candidate)) return candidate.string();
    }
    from = end + 1;
  }
  return "";
}

std::string selfDirectory() {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : self.parent_path().string();
}

LaunchPlan planLaunch(const LaunchFile& file, int team_size, const ExecutableLookup& lookup) {
  LaunchPlan plan;
  std::vector<std::vector<int>> robots_of;
  std::set<int> robots;
  for (const ProcessEntry& entry : file.processes) {
    robots_of.push_back(entryRobots(entry, file.defaults, team_size));
    robots.insert(robots_of.back().begin(), robots_of.back().end());
    for (int r : entry.robots) {
      if (std::find(robots_of.back().begin(), robots_of.back().end(), r) ==
          robots_of.back().end()) {
        plan.notes.push_back(entry.name + " for robot " + std::to_string(r) +
                             " left out: the team has " + std::to_string(team_size) + " robots");
      }
    }
  }
  for (int robot : robots) {
    for (std::size_t e = 0; e < file.processes.size(); ++e) {
      const ProcessEntry& entry = file.processes[e];
      const std::vector<int>& wanted = robots_of[e];
      if (std::find(wanted.begin(), wanted.end(), robot) == wanted.end()) continue;
      LaunchInstance instance;
      instance.name = entry.name;
      instance.robot = robot;
      instance.executable = entry.executable;
      instance.path = lookup(entry.executable);
      instance.argv = buildCommandLine(entry, robot, file.defaults.bus, instance.path);
      instance.env = entry.env;
      // The robot's clock; an entry's own env wins.
      for (auto& [key, value] : clockEnvironment(file.clocks.of(robot)))
        instance.env.try_emplace(key, value);
      instance.restart = entry.restart;
      instance.main_channel = entry.main_channel;
      instance.optional = entry.optional;
      instance.bus_url = robot == kSimRobot ? bus::simBusUrl(file.defaults.bus)
                                            : bus::robotBusUrl(robot, file.defaults.bus);
      plan.instances.push_back(std::move(instance));
    }
  }
  return plan;
}

std::string commandText(const std::vector<std::string>& argv) {
  std::string line;
  for (const std::string& word : argv) {
    if (!line.empty()) line += ' ';
    line += shellQuote(word);
  }
  return line;
}

}  // namespace fieldline::launch
