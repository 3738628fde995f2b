// What every process's main() shares: the common command-line options and the error handling
// around the body (bus and config errors end the process with a clear message and exit code).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/cli/cli.hpp"

namespace fieldline::bus {

struct CommonOptions {
  // 1..6; 0 for processes that serve the whole team (the simulator).
  int robot = 1;
  // Primary bus; empty means robotBusUrl(robot) (simBusUrl() for robot 0).
  std::string bus_url;
  // The simulator's bus; empty means simBusUrl().
  std::string sim_bus_url;
  // trace, debug, info, warn, error.
  std::string log_level = "info";
  // --check-args: parse the arguments and read the configuration, then exit 0 (2 for a
  // problem) before opening a bus, a device or a socket. The launcher's preflight runs every
  // child this way (tools/launch/preflight.hpp).
  bool check_args = false;
  // --print-io: print the channels (and devices, links) this process reads and writes with these
  // arguments, as YAML, then exit 0 before opening anything (common/bus/io.hpp); what
  // `fieldline-launch --graph` draws.
  bool print_io = false;

  // Adds --robot, --bus-url, --sim-bus-url, --log-level, --check-args and --print-io to `app`.
  void addTo(cli::App& app);
  // Fills the defaults and configures logging; call after parsing.
  void resolve(const std::string& process);
};

// Parses "1.0,-0.5,0.2" into exactly `count` finite numbers; throws std::invalid_argument naming
// `what` (e.g. "--pose") otherwise. For command-line options that take a pose or a point.
std::vector<double> parseNumberList(const std::string& text, std::size_t count,
                                    const std::string& what);

// Parses the command line. Returns nothing when the program should go on, else the code main()
// returns: 0 after --help, 2 for bad arguments (CLI11's own codes, e.g. 105, are not ours).
std::optional<int> parseCommandLine(cli::App& app, int argc, char** argv);

// Runs `body` and turns the project's exceptions into messages on stderr and exit codes:
// 2 for configuration errors, 3 for bus errors, 1 for anything else.
int runMain(const std::string& process, const std::function<int()>& body);

}  // namespace fieldline::bus

// Use instead of CLI11_PARSE in main(): exit code 2 for every kind of bad argument.
#define FIELDLINE_PARSE(app, argc, argv)                                                     \
  if (const auto fieldline_parse_exit = ::fieldline::bus::parseCommandLine(app, argc, argv)) \
  return *fieldline_parse_exit
