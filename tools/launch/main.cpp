// fieldline-launch: starts the processes a launch file lists, each on its robot's bus, prefixes
// their output, restarts crashed ones with backoff, stops them all on Ctrl-C / SIGTERM and shows
// a live status table fed by SERVICE_STATUS (tools/launch/launcher.hpp does the work).
#include <cstdio>
#include <string>
#include <vector>

#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"
#include "tools/launch/launcher.hpp"

namespace cli = fieldline::cli;

int main(int argc, char** argv) {
  using namespace fieldline::launch;
  LauncherOptions options;
  bool skip_check_args = false;
  cli::App app{
      "fieldline-launch: starts the processes of a launch file, each on its robot's LCM bus; "
      "prefixes their output with [robot process], restarts crashed ones with backoff, stops "
      "all of them on Ctrl-C or SIGTERM and shows a live status table from SERVICE_STATUS."};
  app.add_option("launch_file", options.launch_file,
                 "Launch file: a path, or a preset name in config/launch/")
      ->capture_default_str();
  app.add_option("--robots", options.robots,
                 "Team size: `all` means robots 1..N (default: defaults.robots of the file)")
      ->check(cli::Range(1, kMaxRobot));
  app.add_option("--robot", options.robot,
                 "This machine is robot N (a real robot): `robots: all` means robot N only "
                 "(default: defaults.robot of the file, or FIELDLINE_ROBOT)")
      ->check(cli::Range(1, kMaxRobot));
  std::vector<std::string> settings;
  app.add_option("--set", settings,
                 "NAME=VALUE: a setting of the launch file (its `settings:`, used as {NAME} in "
                 "args), e.g. --set camera_device=/dev/video2; the environment variable "
                 "FIELDLINE_<NAME> sets it too, --set wins")
      ->allow_extra_args(false);
  int bus_ttl = -1;
  app.add_option("--bus-ttl", bus_ttl,
                 "The buses' multicast ttl for this run (default: defaults.bus.ttl, 0: they stay "
                 "on this machine; 1: a laptop on the robot's network may watch them with "
                 "fieldline-viewer or lcm-spy; docs/launch.md)")
      ->check(cli::Range(0, 255));
  std::string bus_interface;
  auto* interface_option =
      app.add_option("--bus-interface", bus_interface,
                     "With a ttl: the network interface the buses must leave through (default: "
                     "defaults.bus.interface); the multicast route is checked before the start");
  app.add_option("--duration", options.duration_s,
                 "Run this many seconds, then stop everything cleanly (0: until Ctrl-C); the exit "
                 "code is 1 if a process failed or crash-looped meanwhile")
      ->check(cli::Range(0.0, 1e7))
      ->capture_default_str();
  app.add_flag("--no-table", options.no_table,
               "Plain log output (for CI): compact status lines instead of the live table");
  app.add_flag("--dry-run", options.dry_run,
               "Check the launch file and every child's arguments (--check-args), print the "
               "command lines and exit: 0, or 2 with the problems");
  app.add_flag("--graph", options.graph,
               "Print the data flow: every process with the channels it reads and writes (its "
               "own declaration, --print-io), per bus, and the links outside LCM; exit 0 when "
               "every required input has a writer in the launch, 1 when not; starts nothing");
  app.add_flag(
      "--skip-check-args", skip_check_args,
      "Start without running one instance of each entry with --check-args first (--dry-run "
      "always checks every instance)");
  app.add_option("--clock-control", options.clock_control,
                 "A file of robot clock offsets (`ROBOT OFFSET_US` a line): on SIGUSR1 the "
                 "launcher reads it and restarts every process of each robot whose clock it "
                 "changes on the new clock (a clock step; fieldline-eval's clockstep fault; "
                 "docs/faults.md)");
  app.add_option("--status-period", options.status_period_s,
                 "Seconds between compact status lines when there is no live table")
      ->check(cli::Range(0.2, 3600.0))
      ->capture_default_str();
  app.footer(launchFileHelp());
  FIELDLINE_PARSE(app, argc, argv);
  options.check_args = !skip_check_args;
  if (bus_ttl >= 0) options.bus_ttl = bus_ttl;
  if (interface_option->count() > 0) options.bus_interface = bus_interface;
  for (const std::string& s : settings) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0) {
      std::fprintf(stderr, "fieldline-launch: --set %s: expected NAME=VALUE\n", s.c_str());
      return kExitBadLaunch;
    }
    options.settings[s.substr(0, eq)] = s.substr(eq + 1);
  }
  return fieldline::bus::runMain("fieldline-launch", [&] { return Launcher(options).run(); });
}
