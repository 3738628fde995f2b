#include "tools/team_relay/relay_app.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <iostream>
#include <optional>
#include <queue>

#include "common/cli/cli.hpp"
#include "tools/team_relay/relay.hpp"

namespace fieldline::team_relay {

namespace {

using Clock = std::chrono::steady_clock;

struct Pending {
  Clock::time_point due;
  std::uint64_t order;
  sockaddr_in to;
  std::vector<std::uint8_t> bytes;
  bool operator>(const Pending& o) const { return due != o.due ? due > o.due : order > o.order; }
};

// The arguments turned into addresses, delays and a checked schedule.
struct Setup {
  std::vector<sockaddr_in> robots;
  LinkDelays delays;
  std::vector<ScheduledChange> changes;
  std::optional<sockaddr_in> monitor;
};

Setup resolve(const RelayOptions& o) {
  Setup s;
  for (const auto& r : o.robots)
    s.robots.push_back(parseIpv4Endpoint(r));
  const std::size_t n = o.robots.size();
  s.delays = {parsePerRobot(o.up_ms, n, "--up-ms"), parsePerRobot(o.down_ms, n, "--down-ms"),
              parsePerRobot(o.up_jitter_ms, n, "--up-jitter-ms"),
              parsePerRobot(o.down_jitter_ms, n, "--down-jitter-ms"), o.max_delay_ms};
  for (const auto& c : o.schedule)
    s.changes.push_back(parseScheduleEntry(c));
  if (!o.monitor.empty()) s.monitor = parseIpv4Endpoint(o.monitor);
  return s;
}

int senderOf(const Setup& setup, const sockaddr_in& from) {
  int sender = 0;
  for (std::size_t i = 0; i < setup.robots.size(); ++i) {
    if (setup.robots[i].sin_addr.s_addr == from.sin_addr.s_addr) sender = static_cast<int>(i) + 1;
  }
  return sender;
}

}  // namespace

void RelayOptions::addTo(cli::App& app) {
  app.add_option("--port", port, "UDP port to listen on")->capture_default_str();
  app.add_option("--robot", robots, "Robot address host:port, robot 1 first")->required();
  app.add_option("--up-ms", up_ms, "Uplink base delay, ms (one value or one per robot)")
      ->capture_default_str();
  app.add_option("--down-ms", down_ms, "Downlink base delay, ms (one value or one per robot)")
      ->capture_default_str();
  app.add_option("--up-jitter-ms", up_jitter_ms,
                 "Mean of the exponential jitter on the uplink, ms (one value or one per robot)")
      ->capture_default_str();
  app.add_option("--down-jitter-ms", down_jitter_ms,
                 "Mean of the exponential jitter on the downlink, ms (one value or one per robot)")
      ->capture_default_str();
  app.add_option("--max-delay-ms", max_delay_ms, "Cap of the one-way delay, ms")
      ->capture_default_str();
  app.add_option("--loss", loss, "Probability a forwarded copy is dropped")
      ->check(cli::Range(0.0, 1.0));
  app.add_option("--duplicate", duplicate, "Probability a copy is sent twice")
      ->check(cli::Range(0.0, 1.0));
  app.add_option("--reorder", reorder, "Probability a copy is held 5-15 ms longer")
      ->check(cli::Range(0.0, 1.0));
  app.add_option(
      "--schedule", schedule,
      "Changes during the run: 'SECONDS:loss=P,partition=123|456' (partition=none heals)");
  app.add_option("--monitor", monitor,
                 "host:port that also gets a copy of every robot's packet (a sniffer)");
  app.add_option("--seed", seed, "Random seed")->capture_default_str();
  app.add_option("--duration", duration_s, "Seconds to run")->capture_default_str();
}

int runRelay(const RelayOptions& options) {
  Setup setup;
  std::optional<Forwarder> forwarder;
  try {
    setup = resolve(options);
    forwarder.emplace(static_cast<int>(setup.robots.size()), setup.delays,
                      Impairment{options.loss, options.duplicate, options.reorder, {}},
                      options.seed);
  } catch (const std::exception& e) {
    std::cerr << "bad arguments: " << e.what() << "\n";
    return 2;
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in bind_addr{};
  bind_addr.sin_family = AF_INET;
  bind_addr.sin_port = htons(static_cast<std::uint16_t>(options.port));
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&bind_addr), sizeof bind_addr) != 0) {
    std::cerr << "cannot bind UDP port " << options.port << ": " << std::strerror(errno) << "\n";
    return 1;
  }
  std::priority_queue<Pending, std::vector<Pending>, std::greater<>> queue;
  std::uint64_t order = 0;
  std::size_t next_change = 0;
  const auto start = Clock::now();
  // The schedule's zero on the system clock, for the test's analysis.
  std::cerr << fmt::format("relay start_us={}\n",
                           std::chrono::duration_cast<std::chrono::microseconds>(
                               std::chrono::system_clock::now().time_since_epoch())
                               .count());
  const auto end = start + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(options.duration_s));
  std::vector<std::uint8_t> buffer(65536);
  while (Clock::now() < end) {
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    while (next_change < setup.changes.size() && setup.changes[next_change].at_s <= elapsed) {
      applyChange(forwarder->impairment(), setup.changes[next_change].text);
      std::cerr << fmt::format("relay {:.1f} s: {}\n", elapsed, setup.changes[next_change].text);
      ++next_change;
    }
    auto now = Clock::now();
    while (!queue.empty() && queue.top().due <= now) {
      const Pending& p = queue.top();
      ::sendto(fd, p.bytes.data(), p.bytes.size(), 0, reinterpret_cast<const sockaddr*>(&p.to),
               sizeof p.to);
      queue.pop();
    }
    int wait_ms = 5;
    if (!queue.empty()) {
      wait_ms = static_cast<int>(std::clamp<long>(
          std::chrono::duration_cast<std::chrono::milliseconds>(queue.top().due - now).count(), 0,
          5));
    }
    pollfd pfd{fd, POLLIN, 0};
    if (::poll(&pfd, 1, wait_ms) <= 0) continue;
    for (int n = 0; n < 1000; ++n) {
      sockaddr_in from{};
      socklen_t from_len = sizeof from;
      const ssize_t got = ::recvfrom(fd, buffer.data(), buffer.size(), MSG_DONTWAIT,
                                     reinterpret_cast<sockaddr*>(&from), &from_len);
      if (got < 0) break;
      now = Clock::now();
      const int sender = senderOf(setup, from);
      const std::vector<std::uint8_t> bytes(buffer.begin(), buffer.begin() + got);
      if (sender != 0 && setup.monitor) queue.push({now, order++, *setup.monitor, bytes});
      for (const Copy& c : forwarder->route(sender)) {
        queue.push({now + std::chrono::microseconds(static_cast<long>(c.delay_ms * 1000.0)),
                    order++, setup.robots[static_cast<std::size_t>(c.to - 1)], bytes});
      }
    }
  }
  const RelayCounts& k = forwarder->counts();
  std::cerr << fmt::format(
      "relay done: {} forwarded, {} lost, {} blocked by partition, {} from "
      "unknown senders\n",
      k.forwarded, k.dropped, k.blocked, k.foreign);
  ::close(fd);
  return 0;
}

}  // namespace fieldline::team_relay
