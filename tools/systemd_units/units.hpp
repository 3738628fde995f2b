// systemd units from a launch file (the one fieldline-launch runs): one templated service per
// process (`fieldline-<name>@.service`, the instance is the robot number, 0 for the simulator's
// processes), one target per robot (`fieldline-robot<N>.target`) that wants that robot's
// instances, and one environment file per robot with its bus URLs. Plain functions: files in,
// text out.
#pragma once

#include <map>
#include <string>

#include "tools/launch/launch_file.hpp"

namespace fieldline::systemd_units {

struct UnitOptions {
  // Team size for `robots: all` (0: the launch file's defaults.robots).
  int robots = 0;
  // Where the fieldline executables are installed (ExecStart needs absolute paths).
  std::string bin_dir = "/usr/local/bin";
  // Where the robots' environment files are installed (EnvironmentFile=).
  std::string env_dir = "/etc/fieldline";
  // FIELDLINE_ROOT of the processes: the installed config/ (presets, launch files).
  std::string root = "/usr/local/share/fieldline";
  // User= of every service; empty: root.
  std::string user;
};

// File name -> content: `fieldline-<name>@.service` for each process, `fieldline-robot<N>.target`
// for each robot (0: the simulator's processes), `robot<N>.env` for each robot (to go into
// env_dir). Throws std::invalid_argument for options that cannot be written into a unit (a
// relative bin_dir, a name with characters systemd does not allow).
std::map<std::string, std::string> generateUnits(const launch::LaunchFile& file,
                                                 const UnitOptions& options);

// One ExecStart= word: quoted when it holds whitespace or quotes, with systemd's specifier and
// variable characters (% and $) escaped so the process gets `word` unchanged.
std::string execWord(const std::string& word);

}  // namespace fieldline::systemd_units
