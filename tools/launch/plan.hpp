// From a launch file to the concrete processes: one instance per (process, robot), its command
// line with the bus options every fieldline process understands, and where its executable is.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "tools/launch/launch_file.hpp"

namespace fieldline::launch {

// One process for one robot.
struct LaunchInstance {
  // Process name from the launch file.
  std::string name;
  // 1..N, or kSimRobot for team-wide processes.
  int robot = 0;
  // Executable as the launch file names it.
  std::string executable;
  // Resolved path; empty when the executable is not built (the instance is skipped).
  std::string path;
  // Full command line, argv[0] first.
  std::vector<std::string> argv;
  // Extra environment on top of the launcher's.
  std::map<std::string, std::string> env;
  RestartPolicy restart = RestartPolicy::kOnFailure;
  // Channel the status table reports; empty: the busiest output channel.
  std::string main_channel;
  // The bus the process publishes SERVICE_STATUS on.
  std::string bus_url;
  // Its entry says `optional: true`: skipped with a warning when not built.
  bool optional = false;

  // "r3 camera", "sim world_sim": the prefix of the process's output lines.
  std::string label() const;
};

struct LaunchPlan {
  std::vector<LaunchInstance> instances;
  // Entries left out and why (robots beyond the team size), for the user.
  std::vector<std::string> notes;
};

// "r3" for robot 3, "sim" for kSimRobot.
std::string robotLabel(int robot);

// Replaces every `{robot}` in `arg` by the robot number.
std::string substituteRobot(const std::string& arg, int robot);

// The command line of `entry` for `robot`: executable, --robot N, --bus-url URL,
// --sim-bus-url URL, then the entry's args. Robot kSimRobot gets the simulator's bus as its own.
std::vector<std::string> buildCommandLine(const ProcessEntry& entry, int robot,
                                          const bus::BusAddress& address,
                                          const std::string& executable_path);

// Returns the path of `executable`, or "" when it does not exist. Names with a '/' are paths;
// other names are looked for in `bin_dir` (where the build puts every fieldline executable),
// then in the directories of `search_path` (the PATH variable, may be null).
std::string findExecutable(const std::string& executable, const std::string& bin_dir,
                           const char* search_path);

// Directory of the running executable.
std::string selfDirectory();

using ExecutableLookup = std::function<std::string(const std::string& executable)>;

// Instances for a team of `team_size` robots, ordered by robot (the simulator first), then by
// their order in the file; robots above team_size are left out with a note.
LaunchPlan planLaunch(const LaunchFile& file, int team_size, const ExecutableLookup& lookup);

// `argv` as one line a POSIX shell would run (arguments quoted where needed).
std::string commandText(const std::vector<std::string>& argv);

}  // namespace fieldline::launch
