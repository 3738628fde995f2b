#include "common/bus/cli.hpp"

#include <cmath>
#include <iostream>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "common/bus/node.hpp"
#include "common/config/config.hpp"

namespace fieldline::bus {

void CommonOptions::addTo(cli::App& app) {
  app.add_option("--robot", robot, "Robot number 1..6 (0: team-wide process)")
      ->check(cli::Range(0, 99))
      ->capture_default_str();
  app.add_option("--bus-url", bus_url,
                 "LCM URL of this process's bus (default: robot N's bus, "
                 "udpm://239.255.76.67:<7667+N>?ttl=0...)");
  app.add_option("--sim-bus-url", sim_bus_url,
                 "LCM URL of the simulator's bus (default udpm://239.255.76.67:7667?ttl=0...)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn or error")
      ->check(cli::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  app.add_flag("--check-args", check_args,
               "Parse the arguments and read the configuration, then exit: 0 when valid, 2 when "
               "not; starts nothing");
  app.add_flag("--print-io", print_io,
               "Print the channels this process reads and writes with these arguments (YAML), "
               "then exit; starts nothing (fieldline-launch --graph draws them)");
}

void CommonOptions::resolve(const std::string& process) {
  if (bus_url.empty()) bus_url = robot > 0 ? robotBusUrl(robot) : simBusUrl();
  if (sim_bus_url.empty()) sim_bus_url = simBusUrl();
  spdlog::set_level(spdlog::level::from_str(log_level));
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ " + process + "[" + std::to_string(robot) + "] %v");
}

std::vector<double> parseNumberList(const std::string& text, std::size_t count,
                                    const std::string& what) {
  std::vector<double> out;
  std::size_t start = 0;
  bool ok = true;
  while (ok) {
    const std::size_t comma = text.find(',', start);
    const std::string part = text.substr(start, comma == std::string::npos ? comma : comma - start);
    std::size_t used = 0;
    double v = 0.0;
    try {
      v = std::stod(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    ok = !part.empty() && used == part.size() && std::isfinite(v);
    if (ok) out.push_back(v);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (!ok || out.size() != count) {
    throw std::invalid_argument(what + " expects " + std::to_string(count) +
                                " comma-separated numbers, got '" + text + "'");
  }
  return out;
}

std::optional<int> parseCommandLine(cli::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    // Prints the help or the error; a success code (--help, --version) stays 0.
    const int cli_code = app.exit(e);
    return cli_code == 0 ? 0 : 2;
  }
  return std::nullopt;
}

int runMain(const std::string& process, const std::function<int()>& body) {
  try {
    return body();
  } catch (const config::Error& e) {
    std::cerr << process << ": config error: " << e.what() << "\n";
    return 2;
  } catch (const BusError& e) {
    std::cerr << process << ": bus error: " << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << process << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace fieldline::bus
