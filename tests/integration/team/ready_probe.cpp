// fieldline-ready-probe: the observer of tests/integration/team. Listens to SERVICE_STATUS on the
// simulator's bus and the robots' buses until every expected process's latest report says ok
// (exit 0, after listening --settle seconds more) or the timeout passes (exit 1, naming the
// processes that are not ok and why). Prints one JSON line per process heard: its bus, name,
// state, seconds until its first ok report, and the channels it publishes (so the test checks the
// traffic of whatever processes exist).
#include <map>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/urls.hpp"
#include "common/cli/cli.hpp"
#include "common/time/clock.hpp"

using namespace fieldline;

namespace {

struct Heard {
  int state = -1;
  std::string last_error;
  std::set<std::string> outputs;
  double first_ok_s = -1;
};

std::string stateName(int state) {
  switch (state) {
    case service_status_t::STATE_OK:
      return "ok";
    case service_status_t::STATE_WARN:
      return "warn";
    case service_status_t::STATE_ERROR:
      return "error";
    default:
      return "silent";
  }
}

// JSON string literal of `text` (quotes, backslashes and control characters escaped).
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04x}", c);
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Waits until every expected fieldline process reports ok in SERVICE_STATUS (exit 0) or the "
      "timeout passes (exit 1). Prints one JSON line per process heard."};
  int robots = 6;
  bool sim = false;
  double timeout_s = 60.0;
  double settle_s = 2.5;
  std::vector<std::string> expected;
  bus::BusAddress address;
  app.add_option("--robots", robots, "Listen to robots 1..N")
      ->check(cli::Range(0, 99))
      ->capture_default_str();
  app.add_flag("--sim", sim, "Also listen to the simulator's bus");
  app.add_option("--timeout", timeout_s, "Seconds to wait at most")
      ->check(cli::Range(0.1, 3600.0))
      ->capture_default_str();
  app.add_option("--settle", settle_s,
                 "Seconds to go on listening once all are ok, to learn every process's outputs")
      ->check(cli::Range(0.0, 60.0))
      ->capture_default_str();
  app.add_option("--expect", expected, "Processes that must report ok, as BUS/PROCESS (r1/camera)")
      ->required();
  app.add_option("--base-port", address.base_port, "Port of the simulator's bus; robot N is base+N")
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    const int code = app.exit(e);  // prints the help or the problem
    return code == 0 ? 0 : 2;
  }

  return bus::runMain("ready_probe", [&] {
    SystemClock clock;
    std::vector<std::pair<std::string, std::string>> buses;  // name, url
    if (sim) buses.emplace_back("sim", bus::simBusUrl(address));
    for (int r = 1; r <= robots; ++r)
      buses.emplace_back("r" + std::to_string(r), bus::robotBusUrl(r, address));
    if (buses.empty())
      throw std::invalid_argument("nothing to listen to (--robots 0 and no --sim)");

    const Utime start = clock.now();
    std::map<std::string, Heard> heard;  // "r1/camera"
    bus::Node node(
        {.process = "ready_probe", .robot_id = 0, .url = buses[0].second, .status_period_us = 0},
        clock);
    for (std::size_t i = 0; i < buses.size(); ++i) {
      const bus::BusId id = i == 0 ? bus::kPrimaryBus : node.addBus(buses[i].second);
      node.subscribe(
          bus::channels::kServiceStatus,
          [&, name = buses[i].first](const service_status_t& s) {
            Heard& h = heard[name + "/" + s.process];
            h.state = s.state;
            h.last_error = s.last_error;
            for (int c = 0; c < s.num_channels; ++c) {
              if (s.direction[c] == service_status_t::DIRECTION_OUT &&
                  s.channel[c] != bus::channels::kServiceStatus.name) {
                h.outputs.insert(s.channel[c]);
              }
            }
            if (s.state == service_status_t::STATE_OK && h.first_ok_s < 0)
              h.first_ok_s = static_cast<double>(clock.now() - start) / 1e6;
          },
          id);
    }
    auto notOk = [&] {
      std::vector<std::string> missing;
      for (const std::string& label : expected) {
        const auto it = heard.find(label);
        if (it == heard.end() || it->second.state != service_status_t::STATE_OK)
          missing.push_back(label);
      }
      return missing;
    };

    bus::installStopSignals();
    const Utime end = start + static_cast<Utime>(timeout_s * 1e6);
    while (!notOk().empty() && clock.now() < end && !bus::stopSignalReceived())
      node.spinOnce(50);
    const double waited_s = static_cast<double>(clock.now() - start) / 1e6;
    // A few more reports, so that every process's list of outputs is complete (a process lists a
    // channel from its first message on it).
    const bool all_ok = notOk().empty();
    const Utime settled = clock.now() + static_cast<Utime>(settle_s * 1e6);
    while (all_ok && clock.now() < settled && !bus::stopSignalReceived())
      node.spinOnce(50);

    for (const auto& [label, h] : heard) {
      std::string outputs;
      for (const std::string& o : h.outputs)
        outputs += (outputs.empty() ? "" : ",") + quoted(o);
      const auto slash = label.find('/');
      fmt::print(
          "{{\"bus\":{},\"process\":{},\"state\":{},\"first_ok_s\":{:.2f},\"outputs\":[{}],"
          "\"last_error\":{}}}\n",
          quoted(label.substr(0, slash)), quoted(label.substr(slash + 1)),
          quoted(stateName(h.state)), h.first_ok_s, outputs, quoted(h.last_error));
    }
    const std::vector<std::string> missing = all_ok ? std::vector<std::string>{} : notOk();
    for (const std::string& label : missing) {
      const auto it = heard.find(label);
      fmt::print(stderr, "ready_probe: {} is {} after {:.1f} s{}\n", label,
                 it == heard.end() ? "silent" : stateName(it->second.state), waited_s,
                 it == heard.end() || it->second.last_error.empty()
                     ? ""
                     : " (last error: " + it->second.last_error + ")");
    }
    if (missing.empty())
      fmt::print(stderr, "ready_probe: all {} processes ok after {:.1f} s\n", expected.size(),
                 waited_s);
    return missing.empty() ? 0 : 1;
  });
}
