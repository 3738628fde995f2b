#include "tools/team_relay/relay.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace fieldline::team_relay {

void applyChange(Impairment& impairment, const std::string& text) {
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) throw std::invalid_argument("schedule item '" + item + "'");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    if (key == "loss") {
      impairment.loss = std::stod(value);
    } else if (key == "duplicate") {
      impairment.duplicate = std::stod(value);
    } else if (key == "reorder") {
      impairment.reorder = std::stod(value);
    } else if (key == "partition") {
      impairment.groups.clear();
      if (value == "none") continue;
      std::stringstream groups(value);
      std::string g;
      while (std::getline(groups, g, '|')) {
        impairment.groups.emplace_back();
        for (char c : g) {
          if (c < '1' || c > '9') {
            throw std::invalid_argument("partition '" + value + "': robot ids are digits 1-9");
          }
          impairment.groups.back().push_back(c - '0');
        }
      }
    } else {
      throw std::invalid_argument("unknown schedule key '" + key +
                                  "' (loss, duplicate, reorder, partition)");
    }
  }
}

bool sameSide(const Impairment& impairment, int a, int b) {
  for (const auto& g : impairment.groups) {
    const bool ha = std::find(g.begin(), g.end(), a) != g.end();
    const bool hb = std::find(g.begin(), g.end(), b) != g.end();
    if (ha || hb) return ha && hb;
  }
  return true;
}

ScheduledChange parseScheduleEntry(const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) {
    throw std::invalid_argument("schedule '" + text + "' is not SECONDS:CHANGE");
  }
  ScheduledChange change{std::stod(text.substr(0, colon)), text.substr(colon + 1)};
  Impairment check;
  applyChange(check, change.text);
  return change;
}

std::vector<double> parsePerRobot(const std::string& text, std::size_t n, const std::string& what) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
    out.push_back(std::stod(item));
  if (out.size() == 1) out.assign(n, out[0]);
  if (out.size() != n) throw std::invalid_argument(what + ": one value or one per robot");
  return out;
}

sockaddr_in parseIpv4Endpoint(const std::string& text) {
  const auto colon = text.rfind(':');
  sockaddr_in a{};
  a.sin_family = AF_INET;
  if (colon == std::string::npos ||
      ::inet_pton(AF_INET, text.substr(0, colon).c_str(), &a.sin_addr) != 1) {
    throw std::invalid_argument("address '" + text + "' is not a.b.c.d:port");
  }
  const int port = std::stoi(text.substr(colon + 1));
  if (port <= 0 || port > 65535) throw std::invalid_argument("port of '" + text + "'");
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  return a;
}

Forwarder::Forwarder(int num_robots, LinkDelays delays, Impairment impairment, unsigned seed)
    : num_robots_(num_robots),
      delays_(std::move(delays)),
      impairment_(std::move(impairment)),
      rng_(seed) {
  const auto n = static_cast<std::size_t>(num_robots);
  if (delays_.up_ms.size() != n || delays_.down_ms.size() != n ||
      delays_.up_jitter_ms.size() != n || delays_.down_jitter_ms.size() != n) {
    throw std::invalid_argument("link delays need one value per robot");
  }
}

double Forwarder::hop(double base_ms, double mean_ms) {
  return base_ms + (mean_ms > 0 ? std::exponential_distribution<double>(1.0 / mean_ms)(rng_) : 0.0);
}

std::vector<Copy> Forwarder::route(int sender) {
  std::vector<Copy> copies;
  if (sender == 0) ++counts_.foreign;
  for (int to = 1; to <= num_robots_; ++to) {
    if (to == sender) continue;
    if (sender == 0) {  // the attacker: straight through
      copies.push_back({to, 0.0});
      continue;
    }
    if (!sameSide(impairment_, sender, to)) {
      ++counts_.blocked;
      continue;
    }
    if (unit_(rng_) < impairment_.loss) {
      ++counts_.dropped;
      continue;
    }
    const auto s = static_cast<std::size_t>(sender - 1), r = static_cast<std::size_t>(to - 1);
    const int n = unit_(rng_) < impairment_.duplicate ? 2 : 1;
    for (int c = 0; c < n; ++c) {
      double delay_ms =
          std::min(delays_.max_ms, hop(delays_.up_ms[s], delays_.up_jitter_ms[s]) +
                                       hop(delays_.down_ms[r], delays_.down_jitter_ms[r]));
      if (unit_(rng_) < impairment_.reorder) delay_ms += 5.0 + 10.0 * unit_(rng_);
      copies.push_back({to, delay_ms});
      ++counts_.forwarded;
    }
  }
  return copies;
}

}  // namespace fieldline::team_relay
