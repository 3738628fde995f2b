// fieldline-systemd-units: systemd units for a robot from the launch file fieldline-launch runs
// (one templated service per process and a templated target: the instance is the robot number).
// See docs/robot-install.md.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/config/paths.hpp"
#include "tools/launch/launch_file.hpp"
#include "tools/systemd_units/units.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Writes systemd units for a launch file into OUTDIR; the unit instance is the robot's "
      "number, so one set serves every robot: fieldline-<process>@.service per process, "
      "fieldline-robot@.target wanting robot N's processes (systemctl enable --now "
      "fieldline-robot@3.target), fieldline-sim.target for `robots: sim` processes, and "
      "robot<N>.env with robot N's buses (install into --env-dir). fieldline's processes are "
      "Type=notify with a watchdog; the launch file's crash loop becomes StartLimitBurst= and "
      "StartLimitIntervalSec=. Example: fieldline-systemd-units real_robot --out units/ (see "
      "docs/robot-install.md)"};
  std::string launch_path;
  std::string out_dir;
  systemd_units::UnitOptions options;
  options.bin_dir = config::executableDirectory();
  app.add_option("launch_file", launch_path, "Launch file (a name in config/launch or a path)")
      ->required();
  app.add_option("--out,-o", out_dir, "Directory to write the units into (created)")->required();
  app.add_option("--robots", options.robots,
                 "Team size: `robots: all` means 1..N and robot<N>.env is written for 1..N "
                 "(default: the launch file's defaults.robots)")
      ->check(cli::Range(1, launch::kMaxRobot));
  app.add_option("--bin-dir", options.bin_dir,
                 "Where the fieldline executables are installed (default: this program's folder)")
      ->capture_default_str();
  app.add_option("--env-dir", options.env_dir, "Where robot<N>.env will be installed")
      ->capture_default_str();
  app.add_option("--override-dir", options.override_dir,
                 "Optional local overrides read after --env-dir's file: <dir>/robot<N>.env "
                 "(\"\": none)")
      ->capture_default_str();
  app.add_option("--team-key", options.team_key,
                 "The team's secret key file on the robot, handed to fieldline-teamcomm with "
                 "LoadCredential= (\"\": teamcomm reads its team config's key_file)")
      ->capture_default_str();
  app.add_option("--watchdog-s", options.watchdog_s,
                 "WatchdogSec= of fieldline's processes (0: none)")
      ->check(cli::Range(0.0, 3600.0))
      ->capture_default_str();
  bool no_bus_route = false;
  app.add_flag("--no-bus-route", no_bus_route,
               "No fieldline-bus-route.service (it routes a ttl-0 bus group to lo)");
  app.add_option("--root", options.root,
                 "FIELDLINE_ROOT of the services (default: unset; the installed binaries find "
                 "<prefix>/share/fieldline themselves)");
  app.add_option("--user", options.user, "User the services run as (default: root)");
  FIELDLINE_PARSE(app, argc, argv);
  options.bus_route = !no_bus_route;

  return bus::runMain("systemd_units", [&]() -> int {
    // Settings from the environment too (FIELDLINE_CAMERA_DEVICE=... for real_robot.yaml).
    const launch::LaunchFile file = launch::loadLaunchFile(
        config::resolvePreset("launch", launch_path), {.environment = launch::processEnvironment});
    std::map<std::string, std::string> files;
    try {
      files = systemd_units::generateUnits(file, options);
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "fieldline-systemd-units: %s\n", e.what());
      return 2;
    }
    std::filesystem::create_directories(out_dir);
    for (const auto& [name, text] : files) {
      const std::string path = out_dir + "/" + name;
      std::ofstream out(path);
      out << text;
      if (!out) throw std::runtime_error("cannot write " + path);
      std::printf("%s\n", path.c_str());
    }
    return 0;
  });
}
