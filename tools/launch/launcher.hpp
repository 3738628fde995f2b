// The launcher's run: read the launch file, plan the instances, check them (preflight.hpp), then
// either print the plan (--dry-run) or supervise the processes with the live status table until
// Ctrl-C, SIGTERM, --duration or the end of every process.
//
//   Launcher launcher(options);
//   launcher.addPlanHook([](const LaunchFile& f, LaunchPlan& p) { /* e.g. per-robot clocks */ });
//   return launcher.run();   // 0, 1 (a process failed or crash-looped), 2 (bad launch file)
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "tools/launch/launch_file.hpp"
#include "tools/launch/plan.hpp"

namespace fieldline::launch {

struct LauncherOptions {
  // A path, or a preset name in config/launch/.
  std::string launch_file = "sim_team";
  // Team size; default: defaults.robots of the file.
  std::optional<int> robots;
  // This machine's robot number (`all` means this robot only); 0: the file's defaults.robot or
  // FIELDLINE_ROBOT.
  int robot = 0;
  // --set NAME=VALUE: settings of the file (the environment's FIELDLINE_<NAME> is read too).
  std::map<std::string, std::string> settings;
  // Stop everything after this many seconds (0: until Ctrl-C).
  double duration_s = 0;
  // Compact status lines instead of the live table.
  bool no_table = false;
  // Check and print the plan, start nothing.
  bool dry_run = false;
  // Print what every process reads and writes (their --print-io) and whether every required
  // input has a writer; start nothing.
  bool graph = false;
  // Seconds between compact status lines.
  double status_period_s = 5;
  // Before starting, run one instance of every entry with --check-args (--dry-run runs every
  // instance, whatever this says).
  bool check_args = true;
  // --bus-ttl, --bus-interface: the file's bus.ttl and bus.interface for this run (watching the
  // robot from another machine: docs/launch.md).
  std::optional<int> bus_ttl;
  // --clock-control: the file of robot clock offsets applied on SIGUSR1 (robot_clocks.hpp).
  std::string clock_control;
  std::optional<std::string> bus_interface;
};

// Exit code for a launch file or child arguments that do not pass the checks.
inline constexpr int kExitBadLaunch = 2;
// Exit code when a process failed (ended with an error and not restarted, or crash-looped).
inline constexpr int kExitProcessFailed = 1;

class Launcher {
 public:
  // Changes the plan after planLaunch, before the checks (per-robot clocks add arguments here).
  using PlanHook = std::function<void(const LaunchFile& file, LaunchPlan& plan)>;

  explicit Launcher(LauncherOptions options);

  void addPlanHook(PlanHook hook);
  // Everything; returns the process's exit code. Throws config::Error for an unreadable file.
  int run();

 private:
  // Loads the file and plans; fills file_, plan_, team_size_.
  void plan();
  // Problems found by the checks (also printed), empty when everything may start.
  std::vector<std::string> preflight() const;
  int printDryRun(const std::vector<std::string>& problems) const;
  // --graph: 0, 1 (a required input without a writer) or 2 (a process did not answer).
  int printGraph() const;
  int supervise();

  LauncherOptions options_;
  std::vector<PlanHook> hooks_;
  std::string path_;
  std::string bin_dir_;
  LaunchFile file_;
  LaunchPlan plan_;
  int team_size_ = 0;
};

// The launch file format and the table's columns, for --help.
const char* launchFileHelp();

}  // namespace fieldline::launch
