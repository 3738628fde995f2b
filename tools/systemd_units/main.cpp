// fieldline-systemd-units: systemd units for a robot from the launch file fieldline-launch runs
// (one templated service per process, one target per robot, one environment file per robot).
// See docs/robot-install.md.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <CLI/CLI.hpp>

#include "common/bus/cli.hpp"
#include "common/config/config.hpp"
#include "tools/launch/launch_file.hpp"
#include "tools/systemd_units/units.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  CLI::App app{
      "Writes systemd units for a launch file into OUTDIR: fieldline-<process>@.service (the "
      "instance is the robot number, 0 for the simulator's processes), fieldline-robot<N>.target "
      "wanting robot N's processes, and robot<N>.env with its bus URLs (install into --env-dir). "
      "Example: fieldline-systemd-units config/launch/real_robot.yaml --out units/ (then see "
      "docs/robot-install.md)"};
  std::string launch_path;
  std::string out_dir;
  systemd_units::UnitOptions options;
  app.add_option("launch_file", launch_path, "Launch file (a name in config/launch or a path)")
      ->required();
  app.add_option("--out,-o", out_dir, "Directory to write the units into (created)")->required();
  app.add_option("--robots", options.robots,
                 "Team size for `robots: all` (default: the launch file's defaults.robots)")
      ->check(CLI::Range(1, launch::kMaxRobot));
  app.add_option("--bin-dir", options.bin_dir, "Where the fieldline executables are installed")
      ->capture_default_str();
  app.add_option("--env-dir", options.env_dir, "Where robot<N>.env will be installed")
      ->capture_default_str();
  app.add_option("--root", options.root,
                 "FIELDLINE_ROOT of the services: the installed project tree with config/")
      ->capture_default_str();
  app.add_option("--user", options.user, "User the services run as (default: root)");
  FIELDLINE_PARSE(app, argc, argv);

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
