#include "services/world_sim/world_sim_node.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include "common/msg/world_state.hpp"
#include "services/world_sim/world_snapshot.hpp"

namespace fieldline::world_sim {

WorldSimNode::WorldSimNode(bus::Node& node, const scenario::Scenario& scenario,
                           WorldSimNodeOptions options)
    : node_(node),
      options_(std::move(options)),
      world_(scenario),
      lines_(world_, options_.pty_dir),
      start_(node.now()) {
  if (!(options_.world_rate > 0.0)) throw std::invalid_argument("world rate must be positive");
  if (!options_.state_file.empty() && !options_.fresh) resumeFromStateFile();
  truth_.field = world_.field().name();
  truth_.scenario = scenario.name;
  truth_.robot_radius = world_.robotParams().radius;
  const auto step_us = std::max<Utime>(1, std::llround(world_.stepSeconds() * 1e6));
  node_.every(step_us, [this] { update(); });
  node_.every(kMicrosPerSecond, [this] { publishMetrics(); });
  if (!options_.state_file.empty()) {
    snapshot_file_.emplace(options_.state_file);
    const auto period_us =
        std::max<Utime>(1000, std::llround(options_.snapshot_period_s * kMicrosPerSecond));
    node_.every(period_us, [this] { writeSnapshot(); });
  }
  node_.declareIo(worldSimIo(scenario, options_.pty_dir));
}

bus::ProcessIo worldSimIo(const scenario::Scenario& scenario, const std::string& pty_dir) {
  bus::ProcessIo io("world_sim");
  io.writes(bus::channels::kSimWorld);
  // The motor controllers' side of each robot's serial line (a firmware emulator each).
  for (const scenario::RobotSpec& robot : scenario.robots)
    io.link("serial", serialLinkPath(pty_dir, robot.id), bus::Link::Direction::kBoth);
  return io;
}

WorldSimNode::~WorldSimNode() {
  if (!options_.state_file.empty()) writeSnapshot();
}

void WorldSimNode::resumeFromStateFile() {
  std::optional<WorldSnapshot> snapshot;
  try {
    snapshot = readSnapshotFile(options_.state_file);
  } catch (const std::runtime_error& e) {
    spdlog::warn("starting the scenario afresh: {}", e.what());
    return;
  }
  if (!snapshot) return;
  if (!options_.supervisor.empty() && snapshot->supervisor != options_.supervisor) {
    spdlog::info(
        "starting the scenario afresh: the snapshot in {} was written under another supervisor "
        "({}; this simulator's: {}), a new run",
        options_.state_file, snapshot->supervisor.empty() ? "none" : snapshot->supervisor,
        options_.supervisor);
    return;
  }
  const double age_s = static_cast<double>(node_.now() - snapshot->saved_utime) * 1e-6;
  if (age_s > options_.resume_within_s || age_s < -1.0) {
    spdlog::info(
        "starting the scenario afresh: the snapshot in {} is {:.1f} s old (resumed "
        "within {:.1f} s)",
        options_.state_file, age_s, options_.resume_within_s);
    return;
  }
  try {
    world_.restore(*snapshot);
  } catch (const std::invalid_argument& e) {
    spdlog::warn("starting the scenario afresh: {}: {}", options_.state_file, e.what());
    return;
  }
  lines_.resumeAt(world_.time());
  // The simulated time goes on from the snapshot's: the time the simulator was away is skipped.
  start_ = node_.now() - static_cast<Utime>(std::llround(world_.time() * 1e6));
  next_world_ = world_.time();
  resumed_ = true;
  spdlog::info(
      "resumed the world from {} at simulated time {:.2f} s ({:.2f} s after it was "
      "written)",
      options_.state_file, world_.time(), age_s);
  node_.setMetric("resumed_at_s", world_.time());
}

void WorldSimNode::writeSnapshot() {
  WorldSnapshot s = world_.snapshot();
  s.saved_utime = node_.now();
  s.supervisor = options_.supervisor;
  try {
    if (snapshot_file_) snapshot_file_->write(encodeSnapshot(s));
  } catch (const std::runtime_error& e) {
    node_.reportError("state_file", e.what());
  }
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
  if (finished() && !end_logged_) {
    end_logged_ = true;
    spdlog::info(
        "the scenario {} ended at {:.2f} s; the world goes on until the simulator is "
        "stopped",
        world_.scenario().name, world_.time());
    node_.setMetric("scenario_ended", 1.0);
  }
  // Real time only: every process stamps with its clock, and SIM_WORLD's stamps must agree
  // with theirs (faster-than-real-time runs go through fieldline-sim-drift, offline).
  const double target = static_cast<double>(node_.now() - start_) * 1e-6;
  // Step only up to the present: a state is never stamped later than it is published.
  while (world_.time() + world_.stepSeconds() <= target) {
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
  // Over the interval since the last SIM_WORLD, not the last step's (published_motion.hpp): a
  // camera carries the state to its exposure with it.
  const std::vector<PublishedMotion>& motion =
      published_motion_.next(robots, world_.time(), 2.5 / options_.world_rate);
  for (std::size_t i = 0; i < robots.size(); ++i) {
    auto& r = truth_.robots[i];
    r.id = robots[i].id;
    r.pose = robots[i].pose;
    r.velocity = motion[i].velocity;
    r.omega = motion[i].omega;
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
