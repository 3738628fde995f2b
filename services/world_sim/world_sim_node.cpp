#include "services/world_sim/world_sim_node.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/msg/world_state.hpp"

namespace fieldline::world_sim {

WorldSimNode::WorldSimNode(bus::Node& node, const scenario::Scenario& scenario,
                           WorldSimNodeOptions options)
    : node_(node),
      options_(std::move(options)),
      world_(scenario),
      lines_(world_, options_.pty_dir),
      start_(node.now()) {
  if (!(options_.world_rate > 0.0)) throw std::invalid_argument("world rate must be positive");
  truth_.field = world_.field().name();
  truth_.scenario = scenario.name;
  truth_.robot_radius = world_.robotParams().radius;
  const auto step_us = std::max<Utime>(1, std::llround(world_.stepSeconds() * 1e6));
  node_.every(step_us, [this] { update(); });
  node_.every(kMicrosPerSecond, [this] { publishMetrics(); });
}

Utime WorldSimNode::utimeAt(double t) const {
  return start_ + static_cast<Utime>(std::llround(t * 1e6));
}

bool WorldSimNode::finished() const {
  const double duration = world_.scenario().duration;
  return duration > 0.0 && world_.time() >= duration;
}

void WorldSimNode::pullSerialLines(double duration) {
  lines_.pullAll(world_.time(), duration);
}

void WorldSimNode::update() {
  if (finished()) {
    node_.requestStop();
    return;
  }
  // Real time only: every process stamps with its clock, and SIM_WORLD's stamps must agree
  // with theirs (faster-than-real-time runs go through fieldline-sim-drift, offline).
  const double target = static_cast<double>(node_.now() - start_) * 1e-6;
  // Step only up to the present: a state is never stamped later than it is published.
  while (world_.time() + world_.stepSeconds() <= target && !finished()) {
    lines_.beforeStep(world_);
    world_.step();
    lines_.afterStep(world_);
    if (world_.time() + 1e-9 >= next_world_) {
      next_world_ += 1.0 / options_.world_rate;
      // When the simulation fell behind (a starved CPU at start-up), states from the catch-up
      // would be stale on arrival: publish only the ones within a period of the present.
      if (target - world_.time() < 1.0 / options_.world_rate) publishWorld();
    }
  }
  for (const auto& error : lines_.takeErrors())
    node_.reportError("pty", error);
}

void WorldSimNode::publishWorld() {
  truth_.utime = utimeAt(world_.time());
  const auto& robots = world_.robots();
  truth_.robots.resize(robots.size());
  for (std::size_t i = 0; i < robots.size(); ++i) {
    auto& r = truth_.robots[i];
    r.id = robots[i].id;
    r.pose = robots[i].pose;
    r.velocity = robots[i].velocity;
    r.omega = robots[i].omega;
    r.kidnaps = robots[i].kidnaps;
  }
  const auto& opponents = world_.opponents();
  truth_.opponents.resize(opponents.size());
  for (std::size_t k = 0; k < opponents.size(); ++k)
    truth_.opponents[k] = {opponents[k].pose, opponents[k].radius};
  truth_.ball = {world_.ball().position, world_.ball().velocity, world_.ball().radius};
  msg::toMessage(truth_, msg_);
  node_.publish(bus::channels::kSimWorld, msg_);
}

void WorldSimNode::publishMetrics() {
  node_.setMetric("sim_time_s", world_.time());
  const double elapsed = static_cast<double>(node_.now() - start_) * 1e-6;
  node_.setMetric("realtime_factor", world_.time() / std::max(1e-6, elapsed));
  for (std::size_t i = 0; i < lines_.size(); ++i) {
    const std::string r = "r" + std::to_string(world_.robots()[i].id) + "_";
    const auto& firmware = lines_.firmware(i);
    node_.setMetric(r + "speed_mps", world_.robots()[i].velocity.norm());
    node_.setMetric(r + "commands_total", static_cast<double>(firmware.stats().commands_accepted));
    node_.setMetric(r + "watchdog_stops", static_cast<double>(firmware.stats().watchdog_stops));
    node_.setMetric(r + "serial_bad_frames",
                    static_cast<double>(firmware.decoderStats().badFrames()));
    node_.setMetric(r + "serial_bytes_dropped", static_cast<double>(lines_.bytesDropped(i)));
  }
}

}  // namespace fieldline::world_sim
