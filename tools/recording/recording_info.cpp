#include "tools/recording/recording_info.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "common/bus/log_file.hpp"
#include "common/config/config.hpp"
#include "tools/launch/launch_file.hpp"

namespace fieldline::recording {

namespace {

std::string readText(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw config::Error(path + ": cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The value after `flag` in a process's argument list, or empty.
std::string argumentAfter(const std::vector<std::string>& args, const std::string& flag) {
  for (std::size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == flag) return args[i + 1];
  }
  return {};
}

}  // namespace

LaunchSettings settingsForField(const std::string& field) {
  LaunchSettings s;
  s.field_name = field;
  s.field_yaml = readText(config::resolvePreset("field", field));
  return s;
}

LaunchSettings settingsFromLaunchFile(const std::string& launch_path) {
  std::string launch_text = readText(launch_path);
  std::string field = "msl";
  std::string fusion_config = "default";
  // The launch file as fieldline-launch reads it (its include, its settings from the
  // environment): fusion's arguments after the settings are filled in.
  const launch::LaunchFile file =
      launch::loadLaunchFile(launch_path, {.environment = launch::processEnvironment});
  for (const launch::ProcessEntry& process : file.processes) {
    if (process.name != "fusion") continue;
    if (auto f = argumentAfter(process.args, "--field"); !f.empty()) field = f;
    if (auto c = argumentAfter(process.args, "--config"); !c.empty()) fusion_config = c;
  }
  // The recording keeps the whole description: the included file's text follows.
  if (!file.include_path.empty()) {
    launch_text += "\n# ---- included: " + file.include_path + "\n" + readText(file.include_path);
  }
  LaunchSettings s = settingsForField(field);
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "launch_file" << YAML::Value << launch_path;
  out << YAML::Key << "launch" << YAML::Value << YAML::Literal << launch_text;
  out << YAML::Key << "fusion_config_name" << YAML::Value << fusion_config;
  out << YAML::Key << "fusion_config" << YAML::Value << YAML::Literal
      << readText(config::resolvePreset("fusion", fusion_config));
  out << YAML::EndMap;
  s.settings_yaml = out.c_str();
  return s;
}

std::string settingsValue(const std::string& settings_yaml, const std::string& key) {
  if (settings_yaml.empty()) return {};
  try {
    const YAML::Node root = YAML::Load(settings_yaml);
    if (root.IsMap() && root[key] && root[key].IsScalar()) return root[key].as<std::string>();
  } catch (const YAML::Exception&) {
  }
  return {};
}

std::vector<std::string> recordingFiles(const std::string& path) {
  if (!std::filesystem::exists(path)) throw std::invalid_argument("no such recording: " + path);
  if (!std::filesystem::is_directory(path)) return {path};
  std::vector<std::string> logs;
  for (const auto& entry : std::filesystem::directory_iterator(path)) {
    if (entry.is_regular_file() && entry.path().extension() == ".lcm")
      logs.push_back(entry.path().string());
  }
  std::sort(logs.begin(), logs.end(), [](const std::string& a, const std::string& b) {
    const bool sim_a = std::filesystem::path(a).filename() == "sim.lcm";
    const bool sim_b = std::filesystem::path(b).filename() == "sim.lcm";
    return sim_a != sim_b ? sim_a : a < b;
  });
  if (logs.empty()) throw std::invalid_argument("no *.lcm log in " + path);
  return logs;
}

RobotClockModel clockOf(const recording_info_t& info) {
  RobotClockModel model;
  model.robot_id = info.bus_robot_id;
  model.error = {info.clock_offset_us, info.clock_drift_ppm, info.clock_reference_us};
  model.source = ClockSource::kRecorded;
  return model;
}

std::optional<recording_info_t> readRecordingInfo(const std::string& path, int max_events) {
  // The info is stamped on the robot's clock, which is not known before it is read.
  bus::LogReader log(path, {.future_tolerance_us = std::numeric_limits<Utime>::max() / 4});
  bus::LogEvent event;
  recording_info_t info;
  for (int n = 0; n < max_events && log.nextEvent(event); ++n) {
    if (event.channel != bus::channels::kRecordingInfo.name) continue;
    if (!log.accept(event)) continue;
    if (info.decode(event.data.data(), 0, static_cast<int>(event.data.size())) !=
        static_cast<int>(event.data.size()))
      continue;
    return info;
  }
  return std::nullopt;
}

RobotClockModel clockOfLog(const std::string& path, int robot_id) {
  if (const auto info = readRecordingInfo(path); info && info->bus_robot_id == robot_id) {
    return clockOf(*info);
  }
  const auto models = estimateClocks(path);
  if (const auto it = models.find(robot_id); it != models.end()) return it->second;
  RobotClockModel none;
  none.robot_id = robot_id;
  return none;
}

}  // namespace fieldline::recording

namespace fieldline::recording {
namespace detail {
extern const char* const kBuildVersion;
}  // namespace detail

const std::string& buildVersion() {
  static const std::string version = detail::kBuildVersion;
  return version;
}

}  // namespace fieldline::recording
