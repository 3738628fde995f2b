#include "tools/launch/launch_file.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <set>

#include <arpa/inet.h>
#include <net/if.h>
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

bool validSettingName(const std::string& name) {
  return !name.empty() && std::islower(static_cast<unsigned char>(name[0])) &&
         std::all_of(name.begin(), name.end(), [](char c) {
           return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
         });
}

std::string settingNames(const std::map<std::string, Setting>& settings) {
  std::string names;
  for (const auto& [name, setting] : settings)
    names += (names.empty() ? "" : ", ") + name;
  return names.empty() ? "none" : names;
}

// What the process entries of one file are read with.
struct EntryContext {
  const std::map<std::string, Setting>* settings = nullptr;
  // The file that defines the settings (the including one), for messages.
  std::string settings_file;
};

// `text` with every `{name}` of a setting replaced by its value; `{robot}` stays for the plan.
// Fails at `key` of `n` for a `{name}` that is no setting. Braces around anything that is not a
// lower-case name are left alone.
std::string substituteSettings(const std::string& text, const EntryContext& context,
                               const config::Node& n, const std::string& key) {
  std::string out;
  std::size_t from = 0;
  while (true) {
    const std::size_t open = text.find('{', from);
    if (open == std::string::npos) break;
    const std::size_t close = text.find('}', open + 1);
    if (close == std::string::npos) break;
    const std::string name = text.substr(open + 1, close - open - 1);
    out.append(text, from, open - from);
    if (!validSettingName(name) || name == "robot") {
      out.append(text, open, close + 1 - open);
    } else if (const auto it = context.settings->find(name); it != context.settings->end()) {
      out += it->second.value;
    } else {
      n.fail(key, "{" + name + "} is not a setting of " + context.settings_file +
                      " (its settings: " + settingNames(*context.settings) + ")");
    }
    from = close + 1;
  }
  out.append(text, from, std::string::npos);
  return out;
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

// A name the kernel could give an interface (empty: none given).
bool isInterfaceName(const std::string& name) {
  return name.size() < IF_NAMESIZE && name.find_first_of("/: \t") == std::string::npos;
}

bus::BusAddress parseBus(const config::Node& n, std::string& interface) {
  bus::BusAddress a;
  interface = n.getOr<std::string>("interface", "");
  if (!isInterfaceName(interface)) {
    n.fail("interface", "'" + interface + "' is not a network interface name");
  }
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
  if (n.has("robot")) {
    d.robot = n.get<int>("robot", 1, kMaxRobot);
  } else {
    acceptEmpty(n, "robot");
  }
  if (n.has("restart")) d.restart = parseRestart(n.getChoice("restart", kRestartChoices));
  acceptEmpty(n, "restart");
  d.stop_grace_s = n.getOr<double>("stop_grace_s", d.stop_grace_s, 0.0, 600.0);
  if (auto b = n.childIf("backoff")) d.backoff = parseBackoff(*b);
  if (auto c = n.childIf("crash_loop")) d.crash_loop = parseCrashLoop(*c);
  if (auto b = n.childIf("bus")) d.bus = parseBus(*b, d.bus_interface);
  n.rejectUnknownKeys();
  return d;
}

// args, restart, env, main_channel and optional of an entry into `p` (args appended).
void parseEntryOptions(const config::Node& n, const EntryContext& context, ProcessEntry& p) {
  if (n.has("args")) {
    for (const std::string& arg : n.getList<std::string>("args"))
      p.args.push_back(substituteSettings(arg, context, n, "args"));
  } else {
    acceptEmpty(n, "args");
  }
  if (n.has("restart")) p.restart = parseRestart(n.getChoice("restart", kRestartChoices));
  acceptEmpty(n, "restart");
  if (auto env = n.childIf("env")) {
    for (const std::string& key : env->keys()) {
      if (key.empty() || key.find('=') != std::string::npos) {
        env->fail(key, "not a valid environment variable name");
      }
      p.env[key] = substituteSettings(env->get<std::string>(key), context, *env, key);
    }
  }
  if (n.has("main_channel")) {
    p.main_channel = n.getChoice(
        "main_channel",
        std::vector<std::string>(bus::kAllChannelNames.begin(), bus::kAllChannelNames.end()));
  }
  acceptEmpty(n, "main_channel");
  if (n.has("optional")) p.optional = n.get<bool>("optional");
  acceptEmpty(n, "optional");
}

ProcessEntry parseProcess(const config::Node& n, const LaunchDefaults& defaults,
                          const EntryContext& context) {
  ProcessEntry p;
  p.file = n.file();
  p.line = n.line();
  p.name = n.get<std::string>("name");
  if (!validName(p.name)) n.fail("name", "'" + p.name + "' must be letters, digits, _ or -");
  p.executable = n.get<std::string>("executable");
  if (p.executable.empty()) n.fail("executable", "must not be empty");
  parseRobots(n, p);
  p.restart = defaults.restart;
  parseEntryOptions(n, context, p);
  n.rejectUnknownKeys();
  return p;
}

// An entry of the including file that names an included process and has no executable: its
// args are added, its other keys replace the included ones. Returns false for `enabled: false`
// (the process is left out).
bool changeIncluded(const config::Node& n, const EntryContext& context, ProcessEntry& p) {
  const bool enabled = n.getOr<bool>("enabled", true);
  // Another program in the process's place (a team's own motor controller adapter).
  if (n.has("executable")) {
    p.executable = n.get<std::string>("executable");
    if (p.executable.empty()) n.fail("executable", "must not be empty");
  }
  if (n.has("robots")) {
    p.all_robots = false;
    p.robots.clear();
    parseRobots(n, p);
  }
  parseEntryOptions(n, context, p);
  n.rejectUnknownKeys();
  return enabled;
}

// The `include:` file: its processes, read with the including file's settings.
std::vector<ProcessEntry> readIncluded(const config::Node& root, const std::string& path,
                                       const LaunchDefaults& defaults,
                                       const EntryContext& context) {
  const config::Node included = config::Node::loadFile(path);
  if (included.has("include")) included.fail("include", "an included file cannot include another");
  std::vector<ProcessEntry> processes;
  std::set<std::string> names;
  for (const config::Node& entry : included.children("processes")) {
    ProcessEntry p = parseProcess(entry, defaults, context);
    if (!names.insert(p.name).second) entry.fail("name", "'" + p.name + "' is used twice");
    processes.push_back(std::move(p));
  }
  if (processes.empty()) root.fail("include", path + " has no processes");
  // Only processes: defaults, settings and clocks belong to the including file.
  included.rejectUnknownKeys();
  return processes;
}

// `include: NAME`: a preset in config/launch/, or a path (with a '/' or ending in .yaml)
// relative to the including file's folder.
std::string includePath(const config::Node& root) {
  const std::string name = root.get<std::string>("include");
  if (name.empty()) root.fail("include", "must not be empty");
  const bool is_path = name.find('/') != std::string::npos || name.ends_with(".yaml");
  if (!is_path) return config::resolvePreset("launch", name);
  const std::filesystem::path path(name);
  if (path.is_absolute()) return name;
  return (std::filesystem::path(root.file()).parent_path() / path).lexically_normal().string();
}

std::map<std::string, Setting> parseSettings(const config::Node& root,
                                             const LaunchOverrides& overrides) {
  std::map<std::string, Setting> settings;
  if (auto s = root.childIf("settings")) {
    for (const std::string& name : s->keys()) {
      if (!validSettingName(name) || name == "robot") {
        s->fail(name,
                "a setting's name is lower-case letters, digits and _ (not `robot`, the "
                "robot number)");
      }
      const std::string value = s->get<std::string>(name);
      if (value.empty()) s->fail(name, "must not be empty");
      settings[name] = {value, "launch file"};
    }
  } else {
    acceptEmpty(root, "settings");
  }
  for (auto& [name, setting] : settings) {
    if (!overrides.environment) break;
    const std::string variable = settingVariable(name);
    if (const auto value = overrides.environment(variable); value && !value->empty()) {
      setting = {*value, "environment " + variable};
    }
  }
  for (const auto& [name, value] : overrides.settings) {
    const auto it = settings.find(name);
    if (it == settings.end()) {
      throw config::Error("--set " + name + ": not a setting of " + root.file() +
                          " (its settings: " + settingNames(settings) + ")");
    }
    if (value.empty()) throw config::Error("--set " + name + ": the value must not be empty");
    it->second = {value, "--set"};
  }
  return settings;
}

int robotOverride(const LaunchOverrides& overrides) {
  if (overrides.robot > 0) return overrides.robot;
  if (!overrides.environment) return 0;
  const auto text = overrides.environment("FIELDLINE_ROBOT");
  if (!text || text->empty()) return 0;
  const auto robot = robotNumber(*text);
  if (!robot || *robot < 1) {
    throw config::Error("FIELDLINE_ROBOT: expected a robot number 1.." + std::to_string(kMaxRobot) +
                        ", got '" + *text + "'");
  }
  return *robot;
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

std::optional<std::string> processEnvironment(const std::string& name) {
  const char* value = std::getenv(name.c_str());
  if (value == nullptr) return std::nullopt;
  return std::string(value);
}

std::string settingVariable(const std::string& name) {
  std::string variable = "FIELDLINE_";
  for (char c : name)
    variable += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return variable;
}

std::vector<int> entryRobots(const ProcessEntry& entry, const LaunchDefaults& defaults,
                             int team_size) {
  std::set<int> robots;
  for (int r : entry.robots) {
    if (r == kSimRobot || r <= team_size || r == defaults.robot) robots.insert(r);
  }
  if (entry.all_robots) {
    if (defaults.robot > 0) {
      robots.insert(defaults.robot);
    } else {
      for (int r = 1; r <= team_size; ++r)
        robots.insert(r);
    }
  }
  return {robots.begin(), robots.end()};
}

LaunchFile parseLaunchFile(const config::Node& root, const LaunchOverrides& overrides) {
  LaunchFile file;
  file.path = root.file();
  file.settings = parseSettings(root, overrides);
  if (auto d = root.childIf("defaults")) file.defaults = parseDefaults(*d);
  if (const int robot = robotOverride(overrides); robot > 0) file.defaults.robot = robot;
  if (overrides.bus_ttl) {
    if (*overrides.bus_ttl < 0 || *overrides.bus_ttl > 255) {
      throw config::Error("--bus-ttl " + std::to_string(*overrides.bus_ttl) +
                          ": 0..255 (0 keeps the buses on this machine, 1 reaches the local "
                          "network)");
    }
    file.defaults.bus.ttl = *overrides.bus_ttl;
  }
  if (overrides.bus_interface) {
    if (!isInterfaceName(*overrides.bus_interface)) {
      throw config::Error("--bus-interface '" + *overrides.bus_interface +
                          "': not a network interface name (list them with ip link)");
    }
    file.defaults.bus_interface = *overrides.bus_interface;
  }
  const EntryContext context{&file.settings, file.path};
  std::set<std::string> names;
  if (root.has("include")) {
    file.include_path = includePath(root);
    file.processes = readIncluded(root, file.include_path, file.defaults, context);
    for (const ProcessEntry& p : file.processes) {
      file.included.push_back(p.name);
      names.insert(p.name);
    }
  } else {
    acceptEmpty(root, "include");
  }
  // With an include, the file's own processes are optional.
  std::vector<config::Node> entries;
  if (file.include_path.empty() || root.has("processes")) {
    entries = root.children("processes");
  }
  acceptEmpty(root, "processes");
  if (entries.empty() && file.processes.empty()) root.fail("processes", "the list is empty");
  std::set<std::string> changed;
  std::set<std::string> disabled;
  for (const config::Node& entry : entries) {
    const std::string name = entry.get<std::string>("name");
    const auto included = std::find_if(file.processes.begin(), file.processes.end(),
                                       [&](const ProcessEntry& p) { return p.name == name; });
    const bool from_include =
        std::find(file.included.begin(), file.included.end(), name) != file.included.end();
    if (from_include) {
      if (!changed.insert(name).second) entry.fail("name", "'" + name + "' is changed twice");
      if (!changeIncluded(entry, context, *included)) disabled.insert(name);
      continue;
    }
    ProcessEntry p = parseProcess(entry, file.defaults, context);
    if (!names.insert(p.name).second) entry.fail("name", "'" + p.name + "' is used twice");
    file.processes.push_back(std::move(p));
  }
  std::erase_if(file.processes, [&](const ProcessEntry& p) { return disabled.contains(p.name); });
  if (file.processes.empty()) root.fail("processes", "every process is left out");
  file.clocks = parseRobotClocks(root, clockReferenceNow());
  root.rejectUnknownKeys();
  return file;
}

LaunchFile loadLaunchFile(const std::string& path, const LaunchOverrides& overrides) {
  return parseLaunchFile(config::Node::loadFile(path), overrides);
}

}  // namespace fieldline::launch
