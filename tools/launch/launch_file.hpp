// The launch file: which processes run for which robots, on which buses, with which restart
// policy. Parsed into plain structs; every error names file:line and the key path.
//
//   defaults:                       # optional section, every key optional
//     robots: 6                     # team size; `all` means robots 1..robots
//     restart: on-failure           # always | on-failure | never
//     stop_grace_s: 3.0             # SIGTERM, then SIGKILL after this long
//     backoff: {initial_s: 0.5, max_s: 10.0, stable_s: 60.0}
//     crash_loop: {restarts: 5, window_s: 30.0}   # this many ends within window_s: failed
//     bus: {group: 239.255.76.67, base_port: 7667, ttl: 0, recv_buf_size: 4194304}
//   processes:
//     - name: camera                # unique, [A-Za-z0-9_-]
//       executable: fieldline-camera
//       robots: all                 # all | sim | 0 | N | a list of those
//       args: [--source, sim]       # `{robot}` is replaced by the robot number
//       restart: always             # optional, overrides defaults.restart
//       env: {KEY: value}           # optional extra environment
//       main_channel: CAMERA_IMAGE  # optional: the channel whose rate the status table shows
//       optional: true              # optional: skip with a warning when not built (else an error)
//   robots:                         # optional: a clock per robot (robot_clocks.hpp)
//     - {id: 1, clock: {offset_s: 0.31, drift_ppm: -22}}
#pragma once

#include <map>
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
  RestartPolicy restart = RestartPolicy::kOnFailure;
  // Time between SIGTERM and SIGKILL when stopping, s.
  double stop_grace_s = 3.0;
  BackoffParams backoff;
  CrashLoopParams crash_loop;
  bus::BusAddress bus;
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
  // Line of the entry in the launch file, for messages.
  int line = 0;
};

struct LaunchFile {
  std::string path;
  LaunchDefaults defaults;
  std::vector<ProcessEntry> processes;
  // The optional `robots:` section: each robot's clock (tools/launch/robot_clocks.hpp).
  RobotClocks clocks;
};

// Checks a multicast group: a dotted IPv4 address in 224.0.0.0/4. Returns "" when valid, else
// what is wrong ("'239.255.76.999' is not an IPv4 address").
std::string checkMulticastGroup(const std::string& group);

// Reads a parsed launch file; throws config::Error naming file:line and key on any problem.
LaunchFile parseLaunchFile(const config::Node& root);
// Loads and parses `path`.
LaunchFile loadLaunchFile(const std::string& path);

}  // namespace fieldline::launch
