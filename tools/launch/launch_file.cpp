#include "tools/launch/launch_file.hpp"

#include <algorithm>
#include <cstdint>
#include <optional>
#include <set>

#include <arpa/inet.h>
#include <netinet/in.h>

#include "common/bus/channels.hpp"

namespace fieldline::launch {
namespace {

const std::vector<std::string> kRestartChoices{"always", "on-failure", "never"};

RestartPolicy parseRestart(const std::string& text) {
  if (text == "always") return RestartPolicy::kAlways;
  if (text == "never") return RestartPolicy::kNever;
  return RestartPolicy::kOnFailure;
}

// Marks an optional key read only under a condition as valid, so rejectUnknownKeys accepts
// `key:` with no value and lists the key among the expected ones.
void acceptEmpty(const config::Node& n, const std::string& key) {
  // An absent key is read as absent, which marks it known too.
  if (!n.acceptEmpty(key) && !n.has(key)) (void)n.getOr<std::string>(key, "");
}

bool validName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
  });
}

// One robot of `robots`: `sim` or a number 0..kMaxRobot; nothing when the text is neither.
std::optional<int> robotNumber(const std::string& text) {
  if (text == "sim") return kSimRobot;
  try {
    std::size_t used = 0;
    const int robot = std::stoi(text, &used);
    if (used == text.size() && robot >= 0 && robot <= kMaxRobot) return robot;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

std::string badRobot(const std::string& text) {
  return "expected `all`, `sim` or a robot number 0.." + std::to_string(kMaxRobot) + ", got '" +
         text + "'";
}

void parseRobots(const config::Node& entry, ProcessEntry& p) {
  const YAML::Node value = entry.yaml()["robots"];
  if (!value.IsDefined() || value.IsNull() || value.IsScalar()) {
    const std::string text = entry.get<std::string>("robots");
    if (text == "all") {
      p.all_robots = true;
      return;
    }
    const auto robot = robotNumber(text);
    if (!robot) entry.fail("robots", badRobot(text));
    p.robots.push_back(*robot);
    return;
  }
  for (const config::Node& element : entry.children("robots")) {
    const std::string text = element.as<std::string>();
    if (text == "all") element.fail("", "`all` cannot be combined with other robots");
    const auto robot = robotNumber(text);
    if (!robot) element.fail("", badRobot(text));
    if (std::find(p.robots.begin(), p.robots.end(), *robot) != p.robots.end()) {
      element.fail("", "robot " + text + " is listed twice");
    }
    p.robots.push_back(*robot);
  }
  if (p.robots.empty()) entry.fail("robots", "the list is empty");
}

BackoffParams parseBackoff(const config::Node& n) {
  BackoffParams b;
  b.initial_s = n.getOr<double>("initial_s", b.initial_s, 0.001, 3600.0);
  b.max_s = n.getOr<double>("max_s", b.max_s, 0.001, 3600.0);
  b.stable_s = n.getOr<double>("stable_s", b.stable_s, 0.0, 86400.0);
  if (b.max_s < b.initial_s) n.fail("max_s", "must not be smaller than initial_s");
  n.rejectUnknownKeys();
  return b;
}

CrashLoopParams parseCrashLoop(const config::Node& n) {
  CrashLoopParams c;
  c.restarts = n.getOr<int>("restarts", c.restarts, 1, 1000);
  c.window_s = n.getOr<double>("window_s", c.window_s, 0.1, 86400.0);
  n.rejectUnknownKeys();
  return c;
}

bus::BusAddress parseBus(const config::Node& n) {
  bus::BusAddress a;
  a.group = n.getOr<std::string>("group", a.group);
  if (const std::string problem = checkMulticastGroup(a.group); !problem.empty()) {
    n.fail("group", problem);
  }
  a.base_port = n.getOr<int>("base_port", a.base_port, 1024, 65535 - kMaxRobot);
  a.ttl = n.getOr<int>("ttl", a.ttl, 0, 255);
  a.recv_buf_size = n.getOr<int>("recv_buf_size", a.recv_buf_size, 65536, 1 << 30);
  n.rejectUnknownKeys();
  return a;
}

LaunchDefaults parseDefaults(const config::Node& n) {
  LaunchDefaults d;
  d.robots = n.getOr<int>("robots", d.robots, 1, kMaxRobot);
  if (n.has("restart")) d.restart = parseRestart(n.getChoice("restart", kRestartChoices));
  acceptEmpty(n, "restart");
  d.stop_grace_s = n.getOr<double>("stop_grace_s", d.stop_grace_s, 0.0, 600.0);
  if (auto b = n.childIf("backoff")) d.backoff = parseBackoff(*b);
  if (auto c = n.childIf("crash_loop")) d.crash_loop = parseCrashLoop(*c);
  if (auto b = n.childIf("bus")) d.bus = parseBus(*b);
  n.rejectUnknownKeys();
  return d;
}

ProcessEntry parseProcess(const config::Node& n, const LaunchDefaults& defaults) {
  ProcessEntry p;
  p.line = n.line();
  p.name = n.get<std::string>("name");
  if (!validName(p.name)) n.fail("name", "'" + p.name + "' must be letters, digits, _ or -");
  p.executable = n.get<std::string>("executable");
  if (p.executable.empty()) n.fail("executable", "must not be empty");
  parseRobots(n, p);
  if (n.has("args")) {
    p.args = n.getList<std::string>("args");
  } else {
    acceptEmpty(n, "args");
  }
  p.restart = defaults.restart;
  if (n.has("restart")) p.restart = parseRestart(n.getChoice("restart", kRestartChoices));
  acceptEmpty(n, "restart");
  if (auto env = n.childIf("env")) {
    for (const std::string& key : env->keys()) {
      if (key.empty() || key.find('=') != std::string::npos) {
        env->fail(key, "not a valid environment variable name");
      }
      p.env[key] = env->get<std::string>(key);
    }
  }
  if (n.has("main_channel")) {
    p.main_channel = n.getChoice(
        "main_channel",
        std::vector<std::string>(bus::kAllChannelNames.begin(), bus::kAllChannelNames.end()));
  }
  acceptEmpty(n, "main_channel");
  p.optional = n.getOr<bool>("optional", false);
  n.rejectUnknownKeys();
  return p;
}

}  // namespace

std::string checkMulticastGroup(const std::string& group) {
  in_addr address{};
  if (group.empty()) return "must not be empty";
  if (::inet_pton(AF_INET, group.c_str(), &address) != 1) {
    return "'" + group + "' is not an IPv4 address (four numbers 0..255, e.g. 239.255.76.67)";
  }
  const std::uint32_t host = ntohl(address.s_addr);
  if ((host >> 28) != 0xe) {
    return "'" + group + "' is not a multicast group (224.0.0.0 to 239.255.255.255)";
  }
  return "";
}

std::string toString(RestartPolicy policy) {
  switch (policy) {
    case RestartPolicy::kAlways:
      return "always";
    case RestartPolicy::kOnFailure:
      return "on-failure";
    case RestartPolicy::kNever:
      return "never";
  }
  return "?";
}

LaunchFile parseLaunchFile(const config::Node& root) {
  LaunchFile file;
  file.path = root.file();
  if (auto d = root.childIf("defaults")) file.defaults = parseDefaults(*d);
  const std::vector<config::Node> entries = root.children("processes");
  if (entries.empty()) root.fail("processes", "the list is empty");
  std::set<std::string> names;
  for (const config::Node& entry : entries) {
    ProcessEntry p = parseProcess(entry, file.defaults);
    if (!names.insert(p.name).second) entry.fail("name", "'" + p.name + "' is used twice");
    file.processes.push_back(std::move(p));
  }
  file.clocks = parseRobotClocks(root, clockReferenceNow());
  root.rejectUnknownKeys();
  return file;
}

LaunchFile loadLaunchFile(const std::string& path) {
  return parseLaunchFile(config::Node::loadFile(path));
}

}  // namespace fieldline::launch
