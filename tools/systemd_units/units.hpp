// systemd units from a launch file (the one fieldline-launch runs). The robot's number is the
// unit instance, so one set of units serves every robot of the team:
//   fieldline-<name>@.service   one templated service per process (`fieldline-camera@3.service`:
//                               robot 3's camera; instance 0: the simulator's processes)
//   fieldline-robot@.target     wants every per-robot process of robot %i
//   fieldline-sim.target        wants the simulator's processes (`robots: sim`), if any
//   robot<N>.env                robot N's buses (and clock error, if the launch file gives one)
//   fieldline-bus-route.service the bus group's multicast route on lo (buses with ttl 0)
// Plain functions: files in, text out.
#pragma once

#include <map>
#include <string>

#include "tools/launch/launch_file.hpp"

namespace fieldline::systemd_units {

struct UnitOptions {
  // Team size: `robots: all` means 1..robots, and robot<N>.env is written for N = 1..robots
  // (0: the launch file's defaults.robots; never fewer than the highest robot it names).
  int robots = 0;
  // Where the fieldline executables are installed (ExecStart needs absolute paths).
  std::string bin_dir = "/usr/bin";
  // Where robot<N>.env is installed (EnvironmentFile=, required).
  std::string env_dir = "/etc/fieldline";
  // Optional local overrides read after it (EnvironmentFile=-<dir>/robot%i.env); none when empty
  // or the same as env_dir.
  std::string override_dir = "/etc/fieldline";
  // FIELDLINE_ROOT of the processes; empty: not set (the binaries find their data themselves).
  std::string root;
  // User= of every service; empty: root.
  std::string user;
  // The team's secret key, handed to fieldline-teamcomm by systemd (LoadCredential=; the process
  // reads it with --key-file %d/team.key): the key file can stay readable by root alone.
  // Empty: teamcomm uses its team config's key_file.
  std::string team_key = "/etc/fieldline/team.key";
  // WatchdogSec= of fieldline's own processes (they ping from their event loop, Type=notify);
  // 0: no watchdog (Type=notify still).
  double watchdog_s = 10.0;
  // With the launch file's bus at ttl 0: fieldline-bus-route.service, which every service
  // wants, routes the bus group to the loopback interface (LCM needs a multicast route, and a
  // robot may boot without any network).
  bool bus_route = true;
};

// File name -> content (see the top of this file). Throws std::invalid_argument for what cannot
// be written into units: a relative directory, a name systemd does not allow, a process that
// runs on some robots but not others (the units start the same processes on every robot), a
// process that runs both as the simulator's and on robots.
std::map<std::string, std::string> generateUnits(const launch::LaunchFile& file,
                                                 const UnitOptions& options);

// One ExecStart= word: quoted when it holds whitespace or quotes, with systemd's specifier and
// variable characters (% and $) escaped so the process gets `word` unchanged.
std::string execWord(const std::string& word);

}  // namespace fieldline::systemd_units
