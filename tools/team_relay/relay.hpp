// The team test network's access point, without sockets or clocks: which robots a datagram goes
// to and after what delay, under loss, duplication, reordering, asymmetric delays with
// exponential jitter, and partitions that a schedule changes during the run. The relay process
// (relay_app.cpp) and the team attacker share the address parser.
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace fieldline::team_relay {

// What the network does to robot traffic now; changed by the schedule.
struct Impairment {
  double loss = 0.0;       // probability a forwarded copy is dropped
  double duplicate = 0.0;  // probability a copy is sent twice
  double reorder = 0.0;    // probability a copy is held 5-15 ms longer
  // Groups of robot ids (1-based) that hear each other; empty: no partition.
  std::vector<std::vector<int>> groups;
};

// Applies "loss=0.3,partition=123|456" (keys loss, duplicate, reorder, partition; partition=none
// heals). Throws std::invalid_argument naming the bad item.
void applyChange(Impairment& impairment, const std::string& text);

// True when robots a and b (1-based) hear each other under the partition.
bool sameSide(const Impairment& impairment, int a, int b);

// One entry of --schedule: "SECONDS:CHANGE". The change is checked here (throws
// std::invalid_argument), so a typo fails at start and not in the middle of a run.
struct ScheduledChange {
  double at_s = 0.0;
  std::string text;
};
ScheduledChange parseScheduleEntry(const std::string& text);

// "3" (for every robot) or "1,2,3,4,5,6" (one per robot) -> n values; throws otherwise.
std::vector<double> parsePerRobot(const std::string& text, std::size_t n, const std::string& what);

// "a.b.c.d:port" -> address; throws std::invalid_argument.
sockaddr_in parseIpv4Endpoint(const std::string& text);

// One-way delay of a copy: the sender's uplink plus the receiver's downlink, each a base plus an
// exponential jitter of the given mean, capped at max_ms. Vectors are indexed by robot - 1.
struct LinkDelays {
  std::vector<double> up_ms, down_ms, up_jitter_ms, down_jitter_ms;
  double max_ms = 20.0;
};

struct RelayCounts {
  std::int64_t forwarded = 0;  // copies queued for a robot
  std::int64_t dropped = 0;    // copies lost
  std::int64_t blocked = 0;    // copies not sent because of a partition
  std::int64_t foreign = 0;    // datagrams from addresses that are not a robot
};

// A copy of one datagram to send: to robot `to` (1-based) after `delay_ms`.
struct Copy {
  int to = 0;
  double delay_ms = 0.0;
};

class Forwarder {
 public:
  // Throws std::invalid_argument when the delay vectors do not have one entry per robot.
  Forwarder(int num_robots, LinkDelays delays, Impairment impairment, unsigned seed);

  // The copies of a datagram from robot `sender` (1-based; 0: not a robot, which goes to every
  // robot at once and unimpaired, as an attacker's packets on the same network would).
  std::vector<Copy> route(int sender);

  Impairment& impairment() { return impairment_; }
  const RelayCounts& counts() const { return counts_; }

 private:
  double hop(double base_ms, double mean_ms);

  int num_robots_;
  LinkDelays delays_;
  Impairment impairment_;
  std::mt19937 rng_;
  std::uniform_real_distribution<double> unit_{0.0, 1.0};
  RelayCounts counts_;
};

}  // namespace fieldline::team_relay
