// The launch file: which processes run for which robots, on which buses, with which restart
// policy. Parsed into plain structs; every error names file:line and the key path.
//
//   include: robot_processes        # optional: the processes of another file (a preset name in
//                                   # config/launch/ or a path relative to this file); only its
//                                   # `processes:` are taken
//   settings:                       # optional: values for `{name}` in args and env
//     camera_device: /dev/video0    # FIELDLINE_CAMERA_DEVICE or --set camera_device=... wins
//   defaults:                       # optional section, every key optional
//     robots: 6                     # team size; `all` means robots 1..robots
//     robot: 3                      # this machine is robot 3: `all` means robot 3 only
//     restart: on-failure           # always | on-failure | never
//     stop_grace_s: 3.0             # SIGTERM, then SIGKILL after this long
//     backoff: {initial_s: 0.5, max_s: 10.0, stable_s: 60.0}
//     crash_loop: {restarts: 5, window_s: 30.0}   # this many ends within window_s: failed
//     bus: {group: 239.255.76.67, base_port: 7667, ttl: 0, recv_buf_size: 4194304,
//           interface: wlan0}       # ttl > 0: robot buses leave through `interface` (a laptop
//                                   # watches them; docs/launch.md); --bus-ttl/--bus-interface
//   processes:
//     - name: camera                # unique, [A-Za-z0-9_-]
//       executable: fieldline-camera
//       robots: all                 # all | sim | 0 | N | a list of those
//       args: [--source, sim]       # `{robot}`: the robot number; `{name}`: a setting
//       restart: always             # optional, overrides defaults.restart
//       env: {KEY: value}           # optional extra environment
//       main_channel: CAMERA_IMAGE  # optional: the channel whose rate the status table shows
//       optional: true              # optional: skip with a warning when not built (else an error)
//     - name: pilot                 # an included process's name: changes it; args are added
//       args: [--steer, state]      # after its own, other keys (executable too) replace its own
//     - name: viewer                # `enabled: false` leaves an included process out
//       enabled: false
//   robots:                         # optional: a clock per robot (robot_clocks.hpp)
//     - {id: 1, clock: {offset_s: 0.31, drift_ppm: -22}}
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/bus/urls.hpp"
#include "common/config/config.hpp"
#include "tools/launch/robot_clocks.hpp"

namespace fieldline::launch {

// Robot number of team-wide processes (the simulator); `sim` in the launch file.
inline constexpr int kSimRobot = 0;
// Largest robot number a launch file may name (the bus port is base_port + robot).
inline constexpr int kMaxRobot = 99;

enum class RestartPolicy { kAlways, kOnFailure, kNever };

std::string toString(RestartPolicy policy);

struct BackoffParams {
  // Delay before the first restart, s.
  double initial_s = 0.5;
  // The delay doubles on each crash up to this, s.
  double max_s = 10.0;
  // A run at least this long resets the delay to initial_s, s.
  double stable_s = 60.0;
};

// A process that ends `restarts` times within `window_s` seconds is crash-looping: it is not
// restarted again, shows as failed and makes the launcher's exit code non-zero.
struct CrashLoopParams {
  int restarts = 5;
  double window_s = 30.0;
};

struct LaunchDefaults {
  // Team size: `robots: all` expands to 1..robots (the --robots option overrides it).
  int robots = 6;
  // This machine is robot `robot` (a real robot): `robots: all` means this robot only. 0: not
  // set (a simulated team on one machine). FIELDLINE_ROBOT or the launcher's --robot override it.
  int robot = 0;
  RestartPolicy restart = RestartPolicy::kOnFailure;
  // Time between SIGTERM and SIGKILL when stopping, s.
  double stop_grace_s = 3.0;
  BackoffParams backoff;
  CrashLoopParams crash_loop;
  bus::BusAddress bus;
  // `bus.interface`: the network interface the buses leave through when bus.ttl > 0 (the
  // multicast route must name it: tools/launch/bus_route.hpp); empty: wherever the route says.
  std::string bus_interface;
};

struct ProcessEntry {
  std::string name;
  // Executable name (looked up next to fieldline-launch, then in PATH) or a path.
  std::string executable;
  std::vector<std::string> args;
  // `robots: all`: every robot of the team, 1..team size.
  bool all_robots = false;
  // Explicit robot numbers (kSimRobot for team-wide processes), in file order, no duplicates.
  std::vector<int> robots;
  RestartPolicy restart = RestartPolicy::kOnFailure;
  std::map<std::string, std::string> env;
  // Channel whose rate and latency the status table shows; empty: the busiest output.
  std::string main_channel;
  // `optional: true`: an executable that is not built is skipped with a warning instead of
  // being an error (a name that is not found is a typo until said otherwise).
  bool optional = false;
  // File and line of the entry (the included file for an included process), for messages.
  std::string file;
  int line = 0;
};

// A `settings:` value and where it came from.
struct Setting {
  std::string value;
  // "launch file", "environment FIELDLINE_X" or "--set".
  std::string origin;
};

struct LaunchFile {
  std::string path;
  // The included file's path; empty without `include:`.
  std::string include_path;
  LaunchDefaults defaults;
  std::vector<ProcessEntry> processes;
  // Names of the processes that came from the included file, in its order.
  std::vector<std::string> included;
  std::map<std::string, Setting> settings;
  // The optional `robots:` section: each robot's clock (tools/launch/robot_clocks.hpp).
  RobotClocks clocks;
};

// What overrides a launch file's values when it is read: `--set name=value` (wins), then the
// environment (FIELDLINE_<NAME> for a setting, FIELDLINE_ROBOT for defaults.robot).
struct LaunchOverrides {
  std::map<std::string, std::string> settings;
  // This machine's robot number; 0: the file's (or FIELDLINE_ROBOT).
  int robot = 0;
  // Reads an environment variable (nullopt: not set). Default: none is read.
  std::function<std::optional<std::string>(const std::string& name)> environment;
  // --bus-ttl, --bus-interface: the file's bus.ttl and bus.interface for this run.
  std::optional<int> bus_ttl;
  std::optional<std::string> bus_interface;
};

// Reads the process's real environment, for LaunchOverrides::environment.
std::optional<std::string> processEnvironment(const std::string& name);

// The environment variable that overrides setting `name`: camera_device -> FIELDLINE_CAMERA_DEVICE.
std::string settingVariable(const std::string& name);

// Robots an entry runs for in a team of `team_size` (`all`: 1..team_size, or only
// defaults.robot when that is set), in ascending order, kSimRobot first.
std::vector<int> entryRobots(const ProcessEntry& entry, const LaunchDefaults& defaults,
                             int team_size);

// Checks a multicast group: a dotted IPv4 address in 224.0.0.0/4. Returns "" when valid, else
// what is wrong ("'239.255.76.999' is not an IPv4 address").
std::string checkMulticastGroup(const std::string& group);

// Reads a parsed launch file (and the file it includes); throws config::Error naming file:line
// and key on any problem: an unknown key, a `{name}` that is no setting, an override naming no
// setting.
LaunchFile parseLaunchFile(const config::Node& root, const LaunchOverrides& overrides = {});
// Loads and parses `path`.
LaunchFile loadLaunchFile(const std::string& path, const LaunchOverrides& overrides = {});

}  // namespace fieldline::launch
