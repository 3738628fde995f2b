// A recording's description of itself (RECORDING_INFO, lcmtypes/recording_info_t.lcm): made by
// the recorder from what it knows (the robot's clock, the launch file, the field, its own
// version), read back by replay, evaluation and the viewer.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <fieldline/recording_info_t.hpp>

#include "common/time/offset_clock.hpp"
#include "tools/recording/clock_model.hpp"

namespace fieldline::recording {

// The software version this binary was built from: `git describe --always --dirty` at build
// time ("unknown" without git).
const std::string& buildVersion();

// The settings of a robot's processes from a launch file: `launch_file` (its path), `launch` (its
// text, and its included file's after it), the field fusion runs on (fusion's --field, else msl)
// and `fusion_config` (the text of fusion's --config, else config/fusion/default.yaml), as
// fieldline-launch reads the file (its settings from the environment). Throws config::Error for an
// unreadable or invalid file.
struct LaunchSettings {
  std::string settings_yaml;
  std::string field_name = "msl";
  std::string field_yaml;
};
LaunchSettings settingsFromLaunchFile(const std::string& launch_path);
// Without a launch file: the field preset `field` and no process settings.
LaunchSettings settingsForField(const std::string& field);

// The clock model a recording_info_t carries, as replay and evaluation use it.
RobotClockModel clockOf(const recording_info_t& info);

// The first RECORDING_INFO of the log (it is written first by fieldline-record), or nothing for a
// log that has none among its first `max_events` events (lcm-logger's). Throws bus::LogError for
// an unreadable log.
std::optional<recording_info_t> readRecordingInfo(const std::string& path, int max_events = 200);

// The clock of robot `robot_id` in the log: its RECORDING_INFO's, else fitted to the traffic,
// else none.
RobotClockModel clockOfLog(const std::string& path, int robot_id);

// The logs of a recording: a file as it is; a directory's *.lcm files, the simulator's sim.lcm
// first (the truth is read before the estimates matched with it), then the others in name order
// (robot1.lcm, robot1_part002.lcm, ..., robot2.lcm). Throws std::invalid_argument for a missing
// path or a directory without logs.
std::vector<std::string> recordingFiles(const std::string& path);

// A value of the settings YAML (e.g. "fusion_config"), empty when missing or unparsable.
std::string settingsValue(const std::string& settings_yaml, const std::string& key);

}  // namespace fieldline::recording
