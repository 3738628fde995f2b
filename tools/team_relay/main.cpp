// fieldline-team-relay: stands in for the WiFi access point in the team test network (this
// kernel has no netem). Every datagram that reaches its port is forwarded to every robot except
// the sender, after an uplink delay (sender's) plus a downlink delay (receiver's), each a base
// plus an exponential jitter, capped; with loss, duplication, extra reordering delay, and
// partitions of the team into groups that do not hear each other. A schedule changes loss and
// partitions during the run. Datagrams from unknown addresses (an attacker on the same network)
// are forwarded to every robot unimpaired. Stops by itself after --duration.
// The forwarding rules are in relay.hpp, the socket loop in relay_app.cpp.
#include "common/cli/cli.hpp"
#include "tools/team_relay/relay_app.hpp"

namespace cli = fieldline::cli;

int main(int argc, char** argv) {
  cli::App app{
      "Team test network relay: forwards UDP team packets between robots with loss, delay, "
      "asymmetric delay, jitter, duplication, reordering and partitions (see "
      "tests/integration/teamcomm/)."};
  fieldline::team_relay::RelayOptions options;
  options.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  return fieldline::team_relay::runRelay(options);
}
