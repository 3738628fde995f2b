// fieldline-bus-stats: listens to robot buses (and the simulator's) for a while and prints, per
// bus and channel, the message rate, size, latency (utime_published - utime) and seq gaps. It
// checks each packet's fingerprint against its channel's type and reads the header every
// fieldline message starts with; foreign packets are counted apart (traffic.hpp).
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"
#include "tools/bus_stats/traffic.hpp"

using namespace fieldline;

namespace {

// Listens to the robots' (and with --sim the simulator's) buses for duration_s seconds.
bus_stats::TrafficCounter listen(int robots, bool sim, const bus::BusAddress& address,
                                 double duration_s) {
  SystemClock clock;
  std::vector<std::string> urls;
  std::vector<std::string> names;
  if (sim) {
    urls.push_back(bus::simBusUrl(address));
    names.push_back("sim");
  }
  for (int r = 1; r <= robots; ++r) {
    urls.push_back(bus::robotBusUrl(r, address));
    names.push_back("r" + std::to_string(r));
  }
  if (urls.empty()) throw std::invalid_argument("nothing to listen to (--robots 0 and no --sim)");
  bus::Node node({.process = "bus_stats", .robot_id = 0, .url = urls[0], .status_period_us = 0},
                 clock);
  bus_stats::TrafficCounter counter;
  for (std::size_t i = 0; i < urls.size(); ++i) {
    const bus::BusId id = i == 0 ? bus::kPrimaryBus : node.addBus(urls[i]);
    const std::string name = names[i];
    node.subscribeAllRaw(
        [&, name](const std::string& channel, const void* data, int size) {
          counter.onPacket(name, channel, data, size, clock.now());
        },
        id);
  }
  bus::installStopSignals();
  const Utime end = clock.now() + static_cast<Utime>(duration_s * 1e6);
  while (clock.now() < end && !bus::stopSignalReceived())
    node.spinOnce(50);
  return counter;
}

// One row (or JSON line) per bus and channel (the latency percentiles sort the samples).
void printTraffic(bus_stats::TrafficCounter& counter, bool json) {
  if (!json) {
    fmt::print("{:<5} {:<18} {:>7} {:>8} {:>9} {:>9} {:>9} {:>6} {:>7} {:>7} {:>7} {:>7}\n", "bus",
               "channel", "count", "rate_hz", "kB/msg", "lat_p50", "lat_p95", "gaps", "badstmp",
               "foreign", "undecod", "invalid");
  }
  for (auto& [key, t] : counter.traffic()) {
    const bus::Percentiles p = bus::percentiles(t.latency_ms);
    const double rate = t.count > 1 ? static_cast<double>(t.count - 1) * 1e6 /
                                          static_cast<double>(std::max<Utime>(1, t.last - t.first))
                                    : 0.0;
    const double kb = static_cast<double>(t.bytes) /
                      static_cast<double>(std::max<std::int64_t>(1, t.count)) / 1024.0;
    if (json) {
      fmt::print(
          "{{\"bus\":\"{}\",\"channel\":\"{}\",\"count\":{},\"rate_hz\":{:.2f},\"kb_per_msg\":{:."
          "1f},"
          "\"latency_p50_ms\":{:.2f},\"latency_p95_ms\":{:.2f},\"gaps\":{},\"resyncs\":{},"
          "\"suspicious\":{},\"bad_stamps\":{},\"foreign\":{},\"undecodable\":{},\"invalid\":{}}}"
          "\n",
          key.first, key.second, t.count, rate, kb, p.p50, p.p95, t.gaps, t.resyncs, t.suspicious,
          t.bad_stamps, t.foreign, t.undecodable, t.invalid);
    } else {
      fmt::print(
          "{:<5} {:<18} {:>7} {:>8.1f} {:>9.1f} {:>9.1f} {:>9.1f} {:>6} {:>7} {:>7} {:>7} {:>7}\n",
          key.first, key.second, t.count, rate, kb, p.p50, p.p95, t.gaps, t.bad_stamps, t.foreign,
          t.undecodable, t.invalid);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Listens to fieldline buses and prints per channel: rate, size, latency "
      "(utime_published - utime) and messages lost by seq gaps."};
  int robots = 6;
  bool sim = false;
  double duration_s = 5.0;
  bool json = false;
  bus::BusAddress address;
  app.add_option("--robots", robots, "Listen to robots 1..N")
      ->check(cli::Range(0, 99))
      ->capture_default_str();
  app.add_flag("--sim", sim, "Also listen to the simulator's bus");
  app.add_option("--duration", duration_s, "Seconds to listen")
      ->check(cli::Range(0.1, 3600.0))
      ->capture_default_str();
  app.add_option("--base-port", address.base_port, "Port of the simulator's bus; robot N is base+N")
      ->capture_default_str();
  app.add_flag("--json", json, "Print JSON lines instead of a table");
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("bus_stats", [&] {
    bus_stats::TrafficCounter counter = listen(robots, sim, address, duration_s);
    printTraffic(counter, json);
    return 0;
  });
}
