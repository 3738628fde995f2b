#include "tools/systemd_units/units.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <set>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "common/bus/urls.hpp"
#include "tools/launch/robot_clocks.hpp"

namespace fieldline::systemd_units {

namespace {

constexpr const char* kTeamcommExecutable = "fieldline-teamcomm";
constexpr const char* kKeyCredential = "team.key";

std::string restartValue(launch::RestartPolicy policy) {
  switch (policy) {
    case launch::RestartPolicy::kAlways:
      return "always";
    case launch::RestartPolicy::kOnFailure:
      return "on-failure";
    case launch::RestartPolicy::kNever:
      return "no";
  }
  return "no";
}

// Robot numbers an entry runs for, with `all` expanded to 1..team (this robot only when the
// file says which robot this machine is).
std::set<int> robotsOf(const launch::ProcessEntry& entry, const launch::LaunchDefaults& defaults,
                       int team) {
  std::set<int> robots(entry.robots.begin(), entry.robots.end());
  for (const int r : launch::entryRobots(entry, defaults, team))
    robots.insert(r);
  return robots;
}

// `{robot}` becomes the instance specifier; everything else is escaped.
std::string argWord(const std::string& arg) {
  const std::string marker = "{robot}";
  std::string out;
  std::size_t from = 0;
  bool had_marker = false;
  for (std::size_t at = arg.find(marker); at != std::string::npos; at = arg.find(marker, from)) {
    out += arg.substr(from, at - from);
    out += '\x01';  // placeholder, replaced after escaping
    from = at + marker.size();
    had_marker = true;
  }
  out += arg.substr(from);
  std::string word = execWord(out);
  if (had_marker) {
    std::string replaced;
    for (const char c : word)
      replaced += c == '\x01' ? std::string("%i") : std::string(1, c);
    word = replaced;
  }
  return word;
}

void checkName(const std::string& name) {
  // Launch files allow [A-Za-z0-9_-]; check again, a unit name with anything else breaks.
  if (name.empty() || !std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
      })) {
    throw std::invalid_argument("process name '" + name + "' cannot be a unit name");
  }
}

std::string basename(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

// fieldline's own processes run a bus::Node, which speaks sd_notify (READY=1, WATCHDOG=1).
bool speaksNotify(const launch::ProcessEntry& entry) {
  return basename(entry.executable).starts_with("fieldline-");
}

std::string seconds(double s) {
  return fmt::format("{:g}s", s);
}

std::string listOf(const std::set<int>& robots) {
  return fmt::format("{}", fmt::join(robots, ", "));
}

}  // namespace

std::string execWord(const std::string& word) {
  std::string escaped;
  bool quote = word.empty();
  for (const char c : word) {
    switch (c) {
      case '%':
        escaped += "%%";
        break;
      case '$':
        escaped += "$$";
        break;
      case '\\':
        escaped += "\\\\";
        quote = true;
        break;
      case '"':
        escaped += "\\\"";
        quote = true;
        break;
      case '\'':
      case ';':
        escaped += c;
        quote = true;
        break;
      default:
        if (std::isspace(static_cast<unsigned char>(c))) quote = true;
        escaped += c;
    }
  }
  return quote ? "\"" + escaped + "\"" : escaped;
}

namespace {

const std::string kRouteUnit = "fieldline-bus-route.service";

void checkOptions(const UnitOptions& options) {
  for (const auto* dir : {&options.bin_dir, &options.env_dir}) {
    if (dir->empty() || dir->front() != '/') {
      throw std::invalid_argument("'" + *dir + "' is not an absolute path");
    }
  }
  for (const auto* path : {&options.override_dir, &options.root, &options.team_key}) {
    if (!path->empty() && path->front() != '/') {
      throw std::invalid_argument("'" + *path + "' is not an absolute path");
    }
  }
  if (options.watchdog_s < 0) throw std::invalid_argument("the watchdog period is negative");
}

// Which processes run on the robots (every robot the same ones: one template target) and which
// as the simulator's.
struct Targets {
  std::vector<std::string> robot_services;
  std::vector<std::string> sim_services;
  int highest_robot = 0;
};

Targets targetsOf(const launch::LaunchFile& file, int team) {
  // The robot-wide target is a template: every robot runs the same processes.
  std::set<int> robot_set;
  std::string robot_set_owner;
  Targets t;
  t.highest_robot = team;
  auto& robot_services = t.robot_services;
  auto& sim_services = t.sim_services;
  auto& highest_robot = t.highest_robot;
  for (const auto& entry : file.processes) {
    checkName(entry.name);
    std::set<int> robots = robotsOf(entry, file.defaults, team);
    if (robots.empty()) continue;
    const bool sim = robots.count(launch::kSimRobot) > 0;
    if (sim && robots.size() > 1) {
      throw std::invalid_argument(fmt::format(
          "process '{}' (line {}) runs both as the simulator's (sim) and on robots: the units "
          "cannot give one service two targets; make it two entries",
          entry.name, entry.line));
    }
    if (sim) {
      sim_services.push_back("fieldline-" + entry.name + "@0.service");
      continue;
    }
    if (robot_set_owner.empty()) {
      robot_set = robots;
      robot_set_owner = entry.name;
    } else if (robots != robot_set) {
      throw std::invalid_argument(fmt::format(
          "process '{}' (line {}) runs on robots {} but '{}' on {}: the units start the same "
          "processes on every robot (fieldline-robot@N.target); run it on every robot or leave "
          "it out",
          entry.name, entry.line, listOf(robots), robot_set_owner, listOf(robot_set)));
    }
    highest_robot = std::max(highest_robot, *robots.rbegin());
    robot_services.push_back("fieldline-" + entry.name + "@%i.service");
  }
  return t;
}

// Buses that stay on the machine (ttl 0) need a multicast route even when no network is up
// (a robot booting at a venue): the bus group alone goes to the loopback interface, so the
// team link's multicast keeps the system's route. Buses watched from a laptop (ttl > 0 and
// bus.interface, docs/launch.md) get the group routed to that interface instead.
// The route's unit, added to `files` when the buses need one; false when they do not.
bool addRouteUnit(const launch::LaunchFile& file, const UnitOptions& options,
                  std::map<std::string, std::string>& files) {
  const bool local_buses = file.defaults.bus.ttl == 0;
  const std::string route_device = local_buses ? "lo" : file.defaults.bus_interface;
  const bool route = options.bus_route && !route_device.empty();
  if (route) {
    const std::string& group = file.defaults.bus.group;
    files[kRouteUnit] = fmt::format(
        "# Generated by fieldline-systemd-units from {}: {}.\n"
        "[Unit]\n"
        "Description=fieldline: multicast route of the LCM bus group {} on {}\n{}\n"
        "[Service]\n"
        "Type=oneshot\n"
        "RemainAfterExit=yes\n"
        "ExecStart=/bin/sh -c \"ip link set {} multicast on && ip route replace {}/32 dev {}\"\n",
        file.path,
        local_buses ? "the buses have ttl 0, so they stay on this machine"
                    : fmt::format("the buses have ttl {} and leave through {} (watched from "
                                  "another machine)",
                                  file.defaults.bus.ttl, route_device),
        group, local_buses ? "the loopback interface" : route_device,
        // The network's interface is up once the network is.
        local_buses ? "" : "After=network-online.target\nWants=network-online.target\n",
        route_device, group, route_device);
  }
  return route;
}

// One process's service (a template: the instance is the robot number).
std::string serviceUnit(const launch::LaunchFile& file, const UnitOptions& options,
                        const launch::ProcessEntry& entry, const std::string& target, bool route) {
  const std::string executable = entry.executable.find('/') != std::string::npos
                                     ? entry.executable
                                     : options.bin_dir + "/" + entry.executable;
  std::string exec = execWord(executable) +
                     " --robot %i --bus-url ${FIELDLINE_BUS_URL} --sim-bus-url "
                     "${FIELDLINE_SIM_BUS_URL}";
  for (const auto& arg : entry.args)
    exec += " " + argWord(arg);
  const bool takes_key =
      !options.team_key.empty() && basename(entry.executable) == kTeamcommExecutable &&
      std::find(entry.args.begin(), entry.args.end(), "--key-file") == entry.args.end();
  if (takes_key) exec += std::string(" --key-file %d/") + kKeyCredential;
  const bool notify = speaksNotify(entry);
  // The launch file's crash loop: `restarts` ends within `window_s` and it is not started
  // again. systemd counts starts, which is the same number (the first start and a restart
  // after each end but the last).
  const launch::CrashLoopParams& loop = file.defaults.crash_loop;

  std::ostringstream text;
  text << "# Generated by fieldline-systemd-units from " << file.path << " (process '" << entry.name
       << "', line " << entry.line
       << "). The instance is the robot number, 0 for the simulator's processes.\n"
       << "[Unit]\n"
       << "Description=fieldline " << entry.name << " (robot %i)\n"
       << "PartOf=" << target << "\n"
       << "After=network-online.target time-sync.target" << (route ? " " + kRouteUnit : "") << "\n"
       << "Wants=network-online.target" << (route ? " " + kRouteUnit : "") << "\n"
       << "# The launch file's crash loop: " << loop.restarts << " ends in "
       << seconds(loop.window_s) << " and it stays failed (systemctl reset-failed, then start).\n"
       << "StartLimitIntervalSec=" << seconds(loop.window_s) << "\n"
       << "StartLimitBurst=" << loop.restarts << "\n\n"
       << "[Service]\n";
  if (notify) {
    text << "# Ready when its event loop runs; pings the watchdog from that loop.\n"
         << "Type=notify\n"
         << "NotifyAccess=main\n";
    if (options.watchdog_s > 0) text << "WatchdogSec=" << seconds(options.watchdog_s) << "\n";
  } else {
    text << "Type=simple\n";
  }
  text << "EnvironmentFile=" << options.env_dir << "/robot%i.env\n";
  if (!options.override_dir.empty() && options.override_dir != options.env_dir) {
    text << "EnvironmentFile=-" << options.override_dir << "/robot%i.env\n";
  }
  for (const auto& [key, value] : entry.env)
    text << "Environment=" << execWord(key + "=" + value) << "\n";
  if (takes_key) {
    text << "# The team's secret, readable by root alone; the process reads systemd's copy.\n"
         << "LoadCredential=" << kKeyCredential << ":" << options.team_key << "\n";
  }
  if (!options.user.empty()) text << "User=" << options.user << "\n";
  text << "ExecStart=" << exec << "\n"
       << "Restart=" << restartValue(entry.restart) << "\n"
       << "RestartSec=" << seconds(file.defaults.backoff.initial_s) << "\n"
       << "KillSignal=SIGTERM\n"
       << "TimeoutStopSec=" << seconds(file.defaults.stop_grace_s) << "\n"
       << "\n[Install]\n"
       << "WantedBy=" << target << "\n";
  return text.str();
}

// The robots' and the simulator's targets, added to `files`; the robots whose buses need an
// environment file.
std::set<int> addTargetUnits(const launch::LaunchFile& file, const Targets& targets,
                             std::map<std::string, std::string>& files) {
  const auto& robot_services = targets.robot_services;
  const auto& sim_services = targets.sim_services;
  const int highest_robot = targets.highest_robot;
  std::set<int> env_robots;
  if (!robot_services.empty()) {
    std::ostringstream target;
    target << "# Generated by fieldline-systemd-units from " << file.path
           << ". The instance is the robot number: systemctl enable --now "
              "fieldline-robot@3.target\n"
           << "[Unit]\n"
           << "Description=fieldline robot %i: every process of the launch file\n";
    for (const auto& service : robot_services)
      target << "Wants=" << service << "\n";
    target << "\n[Install]\nWantedBy=multi-user.target\n";
    files["fieldline-robot@.target"] = target.str();
    for (int r = 1; r <= highest_robot; ++r)
      env_robots.insert(r);
  }
  if (!sim_services.empty()) {
    std::ostringstream target;
    target << "# Generated by fieldline-systemd-units from " << file.path << ".\n"
           << "[Unit]\n"
           << "Description=fieldline simulator: the launch file's `robots: sim` processes\n";
    for (const auto& service : sim_services)
      target << "Wants=" << service << "\n";
    target << "\n[Install]\nWantedBy=multi-user.target\n";
    files["fieldline-sim.target"] = target.str();
    env_robots.insert(launch::kSimRobot);
  }
  return env_robots;
}

// A robot's (or the simulator's) buses, for its services' EnvironmentFile.
std::string envFile(const launch::LaunchFile& file, const UnitOptions& options, int robot) {
  const bus::BusAddress& address = file.defaults.bus;
  std::ostringstream env;
  env << "# Generated by fieldline-systemd-units from " << file.path << ": "
      << (robot == launch::kSimRobot ? std::string("the simulator")
                                     : fmt::format("robot {}", robot))
      << "'s buses for fieldline-*@" << robot << ".service.\n"
      << "FIELDLINE_BUS_URL="
      << (robot == launch::kSimRobot ? bus::simBusUrl(address) : bus::robotBusUrl(robot, address))
      << "\n"
      << "FIELDLINE_SIM_BUS_URL=" << bus::simBusUrl(address) << "\n";
  const auto clock = launch::clockEnvironment(file.clocks.of(robot));
  if (!clock.empty()) {
    env << "# The robot's clock error (the launch file's robots: section), from one reference "
           "time for all its processes.\n";
    for (const auto& [key, value] : clock)
      env << key << "=" << value << "\n";
  }
  if (!options.root.empty()) env << "FIELDLINE_ROOT=" << options.root << "\n";
  return env.str();
}

}  // namespace

std::map<std::string, std::string> generateUnits(const launch::LaunchFile& file,
                                                 const UnitOptions& options) {
  checkOptions(options);
  const int team = options.robots > 0 ? options.robots : file.defaults.robots;
  const Targets targets = targetsOf(file, team);
  std::map<std::string, std::string> files;
  const bool route = addRouteUnit(file, options, files);
  for (const auto& entry : file.processes) {
    const std::set<int> robots = robotsOf(entry, file.defaults, team);
    if (robots.empty()) continue;
    const bool sim = robots.count(launch::kSimRobot) > 0;
    const std::string target = sim ? "fieldline-sim.target" : "fieldline-robot@%i.target";
    const std::string unit = "fieldline-" + entry.name + "@";

    files[unit + ".service"] = serviceUnit(file, options, entry, target, route);
  }
  const std::set<int> env_robots = addTargetUnits(file, targets, files);
  for (const int robot : env_robots)
    files[fmt::format("robot{}.env", robot)] = envFile(file, options, robot);
  return files;
}

}  // namespace fieldline::systemd_units
