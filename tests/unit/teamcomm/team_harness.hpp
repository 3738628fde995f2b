// The in-process team of the teamcomm node tests: each robot has its own memq:// bus and its own
// clock (offset and drift from true time, and steps), and the team packets travel through an
// in-memory hub with per-direction delays, loss and an attacker's injections. Time is simulated
// and stepped.
#pragma once

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "common/bus/node.hpp"
#include "common/msg/estimates.hpp"
#include "common/msg/team_state.hpp"
#include "common/time/offset_clock.hpp"
#include "teamcomm/teamcomm_node.hpp"

namespace fieldline::teamcomm::test {

// A robot's clock that can also be stepped (an NTP step, an operator setting the time).
class SteppedClock final : public Clock {
 public:
  SteppedClock(const Clock& base, Utime offset_us, double drift_ppm, Utime reference_us)
      : offset_(base, offset_us, drift_ppm, reference_us) {}
  Utime now() const override { return offset_.now() + step_us_; }
  Utime monotonicNow() const override { return offset_.monotonicNow(); }
  void step(Utime by_us) { step_us_ += by_us; }

 private:
  OffsetClock offset_;
  Utime step_us_ = 0;
};

inline constexpr Utime kT0 = 1'800'000'000'000'000;

class Hub;

class HubLink final : public PacketLink {
 public:
  HubLink(Hub& hub, int robot) : hub_(hub), robot_(robot) {}
  bool send(std::span<const std::uint8_t> bytes) override;
  void poll(const std::function<void(std::span<const std::uint8_t>, Utime)>& on_packet) override;
  void deliver(std::vector<std::uint8_t> bytes, Utime at) {
    inbox_.push_back({std::move(bytes), at});
  }

 private:
  struct Datagram {
    std::vector<std::uint8_t> bytes;
    Utime at;
  };
  Hub& hub_;
  int robot_;
  std::deque<Datagram> inbox_;
};

// The access point: forwards every datagram to every link (its sender too, like multicast
// loopback) after a delay of the true clock.
class Hub {
 public:
  explicit Hub(const SimulatedClock& truth) : truth_(truth) {}
  // The link of robot `robot` (a restarted robot gets a new one in its place).
  HubLink& add(int robot) {
    auto& link = links_[robot];
    link = std::make_unique<HubLink>(*this, robot);
    return *link;
  }
  void broadcast(int from, std::span<const std::uint8_t> bytes) {
    if (from > 0) sent_by.push_back({from, {bytes.begin(), bytes.end()}});
    for (auto& [to, link] : links_) {
      if (to != from && loss > 0.0 && std::uniform_real_distribution<double>()(rng) < loss)
        continue;
      // Uplink 1 ms plus an exponential tail, downlink 1-3 ms: asymmetric, 2-22 ms in all.
      Utime delay = 0;
      if (to != from) {
        const double up = 1000.0 + std::exponential_distribution<double>(1.0 / 3000.0)(rng);
        const double down = std::uniform_real_distribution<double>(1000.0, 3000.0)(rng);
        delay = static_cast<Utime>(std::min(up, 19'000.0) + down);
      }
      link->deliver({bytes.begin(), bytes.end()}, truth_.now() + delay);
    }
  }
  Utime now() const { return truth_.now(); }
  // What robot `id` sent, in order (the attacker records it).
  std::vector<std::pair<int, std::vector<std::uint8_t>>> sent_by;
  double loss = 0.0;
  std::mt19937 rng{3};

 private:
  const SimulatedClock& truth_;
  std::map<int, std::unique_ptr<HubLink>> links_;
};

inline bool HubLink::send(std::span<const std::uint8_t> bytes) {
  hub_.broadcast(robot_, bytes);
  return true;
}

inline void HubLink::poll(
    const std::function<void(std::span<const std::uint8_t>, Utime)>& on_packet) {
  const Utime now = hub_.now();
  // Datagrams are delivered in arrival order (reordering happens through the delays).
  std::stable_sort(inbox_.begin(), inbox_.end(),
                   [](const Datagram& a, const Datagram& b) { return a.at < b.at; });
  while (!inbox_.empty() && inbox_.front().at <= now) {
    const Datagram d = std::move(inbox_.front());
    inbox_.pop_front();
    on_packet(d.bytes, now - d.at);
  }
}

inline TeamKey devKey() {
  TeamKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i)
    k.bytes[i] = static_cast<std::uint8_t>(3 * i + 1);
  return k;
}

// One robot: its clock, its bus, a stand-in for fusion, teamcomm, and a TEAM_STATE listener.
struct Robot {
  Robot(int id, const SimulatedClock& truth, Hub& hub, Utime offset_us, double drift_ppm)
      : clock(truth, offset_us, drift_ppm, kT0),
        bus(bus::Connection::open("memq://")),
        node({.process = "teamcomm", .robot_id = id}, clock, bus),
        fusion({.process = "fusion", .robot_id = id, .status_period_us = 0}, clock, bus),
        listener({.process = "listener", .robot_id = id, .status_period_us = 0}, clock, bus),
        team(node, hub.add(id), [] {
          TeamcommOptions o;
          o.key = devKey();
          return o;
        }()) {
    listener.subscribe(bus::channels::kTeamState,
                       [this](const team_state_t& m) { states.push_back(msg::fromMessage(m)); });
  }
  void publishEstimates() {
    robot_state_t r{};
    perception::RobotEstimate e = pose;
    e.utime = clock.now() - 8'000;
    msg::toMessage(e, r);
    fusion.publish(bus::channels::kRobotState, r);
    ball_state_t b{};
    perception::BallEstimate be = ball;
    be.utime = e.utime;
    be.last_seen_utime = e.utime - 30'000;
    msg::toMessage(be, b);
    fusion.publish(bus::channels::kBallState, b);
  }
  void spin() {
    fusion.spinOnce(0);
    node.spinOnce(0);
    listener.spinOnce(0);
  }

  SteppedClock clock;
  std::shared_ptr<bus::Connection> bus;
  bus::Node node;
  bus::Node fusion;
  bus::Node listener;
  TeamcommNode team;
  perception::RobotEstimate pose;
  perception::BallEstimate ball;
  bool publishing = true;
  std::vector<perception::TeamState> states;
};

struct Team {
  explicit Team(std::vector<std::pair<Utime, double>> clocks) {
    for (std::size_t i = 0; i < clocks.size(); ++i) {
      robots.push_back(std::make_unique<Robot>(static_cast<int>(i) + 1, truth, hub, clocks[i].first,
                                               clocks[i].second));
      Robot& r = *robots.back();
      r.pose.pose = {-3.0 + static_cast<double>(i), 1.0, 0.2};
      r.pose.covariance = Eigen::Matrix3d::Identity() * 0.01;
      r.pose.status = perception::LocalizationStatus::kTracking;
      r.ball.valid = true;
      r.ball.x = 2.0;
      r.ball.y = -1.0;
      r.ball.covariance = Eigen::Matrix2d::Identity() * 0.01;
    }
  }
  // Steps true time in 1 ms steps; fusion publishes at 50 Hz.
  void run(double seconds, const std::function<void()>& each_ms = {}) {
    const int steps = static_cast<int>(seconds * 1000);
    for (int s = 0; s < steps; ++s) {
      truth.advance(1000);
      ++ms;
      for (auto& r : robots) {
        if (ms % 20 == 0 && r->publishing) r->publishEstimates();
        r->spin();
      }
      if (each_ms) each_ms();
    }
  }
  // Robot `index` (0-based) restarts all its processes on a clock with this offset and drift.
  void restart(std::size_t index, Utime offset_us, double drift_ppm) {
    const perception::RobotEstimate pose = robots[index]->pose;
    const perception::BallEstimate ball = robots[index]->ball;
    robots[index].reset();
    robots[index] =
        std::make_unique<Robot>(static_cast<int>(index) + 1, truth, hub, offset_us, drift_ppm);
    robots[index]->pose = pose;
    robots[index]->ball = ball;
  }
  // Robot j's clock minus robot i's, now.
  double trueOffset(std::size_t i, std::size_t j) const {
    return static_cast<double>(robots[j]->clock.now() - robots[i]->clock.now());
  }

  SimulatedClock truth{kT0};
  Hub hub{truth};
  std::vector<std::unique_ptr<Robot>> robots;
  long ms = 0;
};

}  // namespace fieldline::teamcomm::test
