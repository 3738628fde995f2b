// fieldline-team-relay: stands in for the WiFi access point in the team test network (this
// kernel has no netem). Every datagram that reaches its port is forwarded to every robot except
// the sender, after an uplink delay (sender's) plus a downlink delay (receiver's), each a base
// plus an exponential jitter, capped; with loss, duplication, extra reordering delay, and
// partitions of the team into groups that do not hear each other. A schedule changes loss and
// partitions during the run. Datagrams from unknown addresses (an attacker on the same network)
// are forwarded to every robot unimpaired. Stops by itself after --duration.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstring>
#include <iostream>
#include <optional>
#include <queue>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

struct Settings {
  double loss = 0.0;
  double duplicate = 0.0;
  double reorder = 0.0;
  // Groups of robot ids (1-based) that hear each other; empty: no partition.
  std::vector<std::vector<int>> groups;
};

struct Change {
  double at_s;
  std::string text;
};

struct Pending {
  Clock::time_point due;
  std::uint64_t order;
  sockaddr_in to;
  std::vector<std::uint8_t> bytes;
  bool operator>(const Pending& o) const { return due != o.due ? due > o.due : order > o.order; }
};

std::vector<double> parseList(const std::string& text, std::size_t n, const std::string& what) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
    out.push_back(std::stod(item));
  if (out.size() == 1) out.assign(n, out[0]);
  if (out.size() != n) throw std::invalid_argument(what + ": one value or one per robot");
  return out;
}

// "loss=0.3,partition=123|456" or "partition=none".
void applyChange(Settings& s, const std::string& text) {
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) throw std::invalid_argument("schedule item '" + item + "'");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    if (key == "loss") {
      s.loss = std::stod(value);
    } else if (key == "duplicate") {
      s.duplicate = std::stod(value);
    } else if (key == "reorder") {
      s.reorder = std::stod(value);
    } else if (key == "partition") {
      s.groups.clear();
      if (value == "none") continue;
      std::stringstream groups(value);
      std::string g;
      while (std::getline(groups, g, '|')) {
        s.groups.emplace_back();
        for (char c : g)
          s.groups.back().push_back(c - '0');
      }
    } else {
      throw std::invalid_argument("unknown schedule key '" + key + "'");
    }
  }
}

bool sameSide(const Settings& s, int a, int b) {
  if (s.groups.empty()) return true;
  for (const auto& g : s.groups) {
    const bool ha = std::find(g.begin(), g.end(), a) != g.end();
    const bool hb = std::find(g.begin(), g.end(), b) != g.end();
    if (ha || hb) return ha && hb;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Team test network relay: forwards UDP team packets between robots with loss, delay, "
      "asymmetric delay, jitter, duplication, reordering and partitions (see "
      "tests/integration/teamcomm/)."};
  int port = 47600;
  std::vector<std::string> robots;
  std::string up_ms = "1", down_ms = "1", up_jitter_ms = "3", down_jitter_ms = "3";
  double max_delay_ms = 20.0, loss = 0.0, duplicate = 0.0, reorder = 0.0, duration_s = 30.0;
  std::vector<std::string> schedule;
  std::string monitor;
  unsigned seed = 1;
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
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--duplicate", duplicate, "Probability a copy is sent twice")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--reorder", reorder, "Probability a copy is held 5-15 ms longer")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option(
      "--schedule", schedule,
      "Changes during the run: 'SECONDS:loss=P,partition=123|456' (partition=none heals)");
  app.add_option("--monitor", monitor,
                 "host:port that also gets a copy of every robot's packet (a sniffer)");
  app.add_option("--seed", seed, "Random seed")->capture_default_str();
  app.add_option("--duration", duration_s, "Seconds to run")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }

  auto address = [](const std::string& text) {
    const auto colon = text.rfind(':');
    sockaddr_in a{};
    a.sin_family = AF_INET;
    if (colon == std::string::npos ||
        ::inet_pton(AF_INET, text.substr(0, colon).c_str(), &a.sin_addr) != 1) {
      throw std::invalid_argument("address '" + text + "' is not a.b.c.d:port");
    }
    a.sin_port = htons(static_cast<std::uint16_t>(std::stoi(text.substr(colon + 1))));
    return a;
  };
  std::vector<sockaddr_in> robot_addr;
  std::vector<double> up, down, up_jitter, down_jitter;
  std::vector<Change> changes;
  std::optional<sockaddr_in> monitor_addr;
  Settings settings;
  try {
    for (const auto& r : robots)
      robot_addr.push_back(address(r));
    up = parseList(up_ms, robots.size(), "--up-ms");
    down = parseList(down_ms, robots.size(), "--down-ms");
    up_jitter = parseList(up_jitter_ms, robots.size(), "--up-jitter-ms");
    down_jitter = parseList(down_jitter_ms, robots.size(), "--down-jitter-ms");
    for (const auto& c : schedule) {
      const auto colon = c.find(':');
      if (colon == std::string::npos) throw std::invalid_argument("schedule '" + c + "'");
      changes.push_back({std::stod(c.substr(0, colon)), c.substr(colon + 1)});
      Settings check;
      applyChange(check, changes.back().text);
    }
    if (!monitor.empty()) monitor_addr = address(monitor);
  } catch (const std::exception& e) {
    std::cerr << "bad arguments: " << e.what() << "\n";
    return 2;
  }
  settings.loss = loss;
  settings.duplicate = duplicate;
  settings.reorder = reorder;

  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in bind_addr{};
  bind_addr.sin_family = AF_INET;
  bind_addr.sin_port = htons(static_cast<std::uint16_t>(port));
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&bind_addr), sizeof bind_addr) != 0) {
    std::cerr << "cannot bind UDP port " << port << ": " << std::strerror(errno) << "\n";
    return 1;
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::priority_queue<Pending, std::vector<Pending>, std::greater<>> queue;
  std::uint64_t order = 0;
  std::size_t next_change = 0;
  std::int64_t forwarded = 0, dropped = 0, blocked = 0, foreign = 0;
  const auto start = Clock::now();
  // The schedule's zero on the system clock, for the test's analysis.
  std::cerr << fmt::format("relay start_us={}\n",
                           std::chrono::duration_cast<std::chrono::microseconds>(
                               std::chrono::system_clock::now().time_since_epoch())
                               .count());
  const auto end = start + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(duration_s));
  std::vector<std::uint8_t> buffer(65536);
  auto hop = [&](double base_ms, double mean_ms) {
    return base_ms +
           (mean_ms > 0 ? std::exponential_distribution<double>(1.0 / mean_ms)(rng) : 0.0);
  };
  while (Clock::now() < end) {
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    while (next_change < changes.size() && changes[next_change].at_s <= elapsed) {
      applyChange(settings, changes[next_change].text);
      std::cerr << fmt::format("relay {:.1f} s: {}\n", elapsed, changes[next_change].text);
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
      int sender = 0;
      for (std::size_t i = 0; i < robot_addr.size(); ++i) {
        if (robot_addr[i].sin_addr.s_addr == from.sin_addr.s_addr) sender = static_cast<int>(i) + 1;
      }
      if (sender == 0) ++foreign;
      const std::vector<std::uint8_t> bytes(buffer.begin(), buffer.begin() + got);
      if (sender != 0 && monitor_addr) queue.push({now, order++, *monitor_addr, bytes});
      for (std::size_t i = 0; i < robot_addr.size(); ++i) {
        const int to = static_cast<int>(i) + 1;
        if (to == sender) continue;
        if (sender == 0) {  // the attacker: straight through
          queue.push({now, order++, robot_addr[i], bytes});
          continue;
        }
        if (!sameSide(settings, sender, to)) {
          ++blocked;
          continue;
        }
        if (unit(rng) < settings.loss) {
          ++dropped;
          continue;
        }
        const int copies = unit(rng) < settings.duplicate ? 2 : 1;
        for (int c = 0; c < copies; ++c) {
          double delay_ms =
              std::min(max_delay_ms, hop(up[static_cast<std::size_t>(sender - 1)],
                                         up_jitter[static_cast<std::size_t>(sender - 1)]) +
                                         hop(down[i], down_jitter[i]));
          if (unit(rng) < settings.reorder) delay_ms += 5.0 + 10.0 * unit(rng);
          queue.push({now + std::chrono::microseconds(static_cast<long>(delay_ms * 1000.0)),
                      order++, robot_addr[i], bytes});
          ++forwarded;
        }
      }
    }
  }
  std::cerr << fmt::format(
      "relay done: {} forwarded, {} lost, {} blocked by partition, {} from "
      "unknown senders\n",
      forwarded, dropped, blocked, foreign);
  ::close(fd);
  return 0;
}
