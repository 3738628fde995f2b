// fieldline-team-attack: the attacker of the team test network. Sniffs the team's packets on
// --listen-port (the relay's monitor copy), then for --for seconds sends to every target: packets
// with forged robot ids under a wrong key, replays of sniffed packets, sniffed packets with one bit
// flipped, truncated and oversized ones, and a flood of random bytes. Prints what it sent by kind
// as one JSON line.
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>
#include <chrono>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <thread>

#include "common/cli/cli.hpp"
#include "teamcomm/packet.hpp"
#include "teamcomm/team_key.hpp"
#include "tools/team_relay/relay.hpp"

using namespace fieldline;

namespace {

using Clock = std::chrono::steady_clock;
using Bytes = std::vector<std::uint8_t>;

struct Options {
  int listen_port = 47601;
  std::vector<std::string> targets;
  double sniff_s = 3.0, attack_s = 4.0, rate_hz = 200.0;

  void addTo(cli::App& app) {
    app.add_option("--listen-port", listen_port, "Port the sniffed copies arrive on")
        ->capture_default_str();
    app.add_option("--target", targets, "a.b.c.d:port to attack")->required();
    app.add_option("--sniff", sniff_s, "Seconds to sniff first")->capture_default_str();
    app.add_option("--for", attack_s, "Seconds to attack")->capture_default_str();
    app.add_option("--rate", rate_hz, "Attack rounds per second (each round sends every kind)")
        ->capture_default_str();
  }
};

Clock::time_point after(double seconds) {
  return Clock::now() +
         std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

std::vector<Bytes> sniff(int fd, double seconds) {
  std::vector<Bytes> sniffed;
  Bytes buffer(2048);
  const auto end = after(seconds);
  while (Clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 20) <= 0) continue;
    const ssize_t got = ::recv(fd, buffer.data(), buffer.size(), MSG_DONTWAIT);
    if (got > 0) sniffed.emplace_back(buffer.begin(), buffer.begin() + got);
  }
  return sniffed;
}

// One round: every kind of bad packet once, built from a random sniffed one.
void attackRound(const std::vector<Bytes>& sniffed, std::mt19937& rng,
                 const teamcomm::TeamKey& wrong, std::uint64_t seq,
                 const std::function<void(const std::string&, const Bytes&)>& send) {
  const auto& real = sniffed[rng() % sniffed.size()];
  // A robot id that is on the team, a pose far from anyone, a send time of now.
  teamcomm::TeamPacket forged;
  forged.team_id = real.size() > 5 ? real[5] : 1;
  forged.robot_id = static_cast<std::uint8_t>(1 + rng() % 6);
  forged.sequence = ~std::uint64_t{0} - seq;
  forged.send_utime = std::chrono::duration_cast<std::chrono::microseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  forged.pose.emplace();
  forged.pose->x = 9.0f;
  send("forged_id_wrong_key", teamcomm::encodePacket(forged, wrong));
  send("replay", real);
  auto flipped = real;
  flipped[rng() % flipped.size()] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
  send("bit_flip", flipped);
  send("truncated", Bytes(real.begin(), real.begin() + static_cast<long>(rng() % real.size())));
  send("oversized", Bytes(1401 + rng() % 500, 0x5a));
  for (int k = 0; k < 5; ++k) {
    Bytes junk(rng() % 1400);
    for (auto& b : junk)
      b = static_cast<std::uint8_t>(rng());
    send("flood", junk);
  }
}

// Attacks for the options' duration; returns the packets sent by kind.
std::map<std::string, std::int64_t> attack(int fd, const Options& o,
                                           const std::vector<sockaddr_in>& to,
                                           const std::vector<Bytes>& sniffed) {
  std::map<std::string, std::int64_t> sent;
  auto send = [&](const std::string& kind, const Bytes& bytes) {
    for (const auto& a : to) {
      ::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&a), sizeof a);
      ++sent[kind];
    }
  };
  std::mt19937 rng(7);
  const teamcomm::TeamKey wrong = teamcomm::generateTeamKey();
  const auto end = after(o.attack_s);
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.rate_hz));
  auto next = Clock::now();
  for (std::uint64_t seq = 1; Clock::now() < end; ++seq) {
    attackRound(sniffed, rng, wrong, seq, send);
    next += period;
    std::this_thread::sleep_until(next);
  }
  return sent;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Team test attacker: forged, replayed, corrupted, truncated, oversized and flooded "
      "team packets."};
  Options options;
  options.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  std::vector<sockaddr_in> to;
  try {
    for (const auto& t : options.targets)
      to.push_back(team_relay::parseIpv4Endpoint(t));
  } catch (const std::exception& e) {
    std::cerr << "bad target: " << e.what() << "\n";
    return 2;
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in bind_addr{};
  bind_addr.sin_family = AF_INET;
  bind_addr.sin_port = htons(static_cast<std::uint16_t>(options.listen_port));
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&bind_addr), sizeof bind_addr) != 0) {
    std::cerr << "cannot bind " << options.listen_port << "\n";
    return 1;
  }
  const std::vector<Bytes> sniffed = sniff(fd, options.sniff_s);
  if (sniffed.empty()) {
    std::cerr << "sniffed nothing: is the relay's --monitor pointing here?\n";
    return 1;
  }
  std::string json = "{";
  std::int64_t total = 0;
  for (const auto& [k, v] : attack(fd, options, to, sniffed)) {
    json += fmt::format("\"{}\":{},", k, v);
    total += v;
  }
  std::cout << json << fmt::format("\"total\":{},\"sniffed\":{}}}", total, sniffed.size()) << "\n";
  ::close(fd);
  return 0;
}
