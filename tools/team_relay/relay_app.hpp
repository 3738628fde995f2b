// fieldline-team-relay's options and its socket loop (the forwarding rules are in relay.hpp).
#pragma once

#include <string>
#include <vector>

namespace fieldline::cli {
class App;
}

namespace fieldline::team_relay {

struct RelayOptions {
  int port = 47600;
  std::vector<std::string> robots;
  std::string up_ms = "1", down_ms = "1", up_jitter_ms = "3", down_jitter_ms = "3";
  double max_delay_ms = 20.0, loss = 0.0, duplicate = 0.0, reorder = 0.0, duration_s = 30.0;
  std::vector<std::string> schedule;
  std::string monitor;
  unsigned seed = 1;

  void addTo(cli::App& app);
};

// Runs the relay for the options' duration. Returns the exit code: 2 for bad arguments (printed),
// 1 when the port cannot be bound, 0 otherwise; the counts go to stderr at the end.
int runRelay(const RelayOptions& options);

}  // namespace fieldline::team_relay
