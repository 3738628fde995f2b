// fieldline-bus-check: is this robot's LCM bus usable? Opens the bus, publishes a status message
// and waits to hear it back. Exit 0 when it loops back, 3 with the remedy when the bus cannot be
// opened, 4 when nothing comes back.
#include <iostream>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Checks that an LCM bus of fieldline works on this machine: opens it, publishes a "
      "SERVICE_STATUS and waits for it to come back."};
  bus::CommonOptions common;
  common.addTo(app);
  int timeout_ms = 2000;
  app.add_option("--timeout-ms", timeout_ms, "How long to wait for the message to come back")
      ->capture_default_str();
  FIELDLINE_PARSE(app, argc, argv);
  return bus::runMain("bus_check", [&] {
    common.resolve("bus_check");
    SystemClock clock;
    bus::Node node({.process = "bus_check",
                    .robot_id = common.robot,
                    .url = common.bus_url,
                    .status_period_us = 0},
                   clock);
    const Utime sent = clock.now();
    bool heard = false;
    node.subscribe(bus::channels::kServiceStatus, [&](const service_status_t& s) {
      if (s.process == "bus_check" && s.pid == ::getpid()) heard = true;
    });
    node.publishStatus();
    while (!heard && clock.now() - sent < static_cast<Utime>(timeout_ms) * kMicrosPerMilli) {
      node.spinOnce(20);
    }
    if (!heard) {
      std::cerr << "bus_check: " << common.bus_url << " opened, but our own message did not come "
                << "back within " << timeout_ms << " ms (multicast loopback off? firewall?)\n";
      return 4;
    }
    std::cout << "bus OK: " << common.bus_url << " (round trip "
              << static_cast<double>(clock.now() - sent) / 1000.0 << " ms)\n";
    return 0;
  });
}
