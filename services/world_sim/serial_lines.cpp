#include "services/world_sim/serial_lines.hpp"

#include <algorithm>

#include <spdlog/spdlog.h>

namespace fieldline::world_sim {

std::string serialLinkPath(const std::string& pty_dir, int robot_id) {
  return pty_dir + "/robot" + std::to_string(robot_id) + ".tty";
}

SerialLines::SerialLines(const World& world, std::string pty_dir)
    : sample_period_(1.0 / world.robotParams().odometry_rate),
      controller_latency_(world.robotParams().controller_latency),
      outages_(world.scenario().serial_outages) {
  std::sort(outages_.begin(), outages_.end(),
            [](const auto& a, const auto& b) { return a.time < b.time; });
  lines_.resize(world.robots().size());
  for (std::size_t i = 0; i < lines_.size(); ++i) {
    auto& line = lines_[i];
    line.robot_id = world.robots()[i].id;
    // Each controller has its own clock, started at a different moment.
    line.firmware = std::make_unique<FirmwareEmulator>(
        world.robotParams(), static_cast<std::uint64_t>(line.robot_id) * 7'000'000ULL);
    line.link_path = serialLinkPath(pty_dir, line.robot_id);
    line.pty = std::make_unique<PseudoTerminal>(line.link_path);
    line.next_sample = sample_period_;
    spdlog::info("robot {}: serial line {} -> {}", line.robot_id, line.link_path,
                 line.pty->slavePath());
  }
}

void SerialLines::pull(std::size_t index, double t, double duration) {
  auto& line = lines_.at(index);
  if (!line.pty) return;
  spdlog::info("robot {}: serial line pulled for {} s", line.robot_id, duration);
  line.pty.reset();
  line.reopen_at = t + duration;
}

void SerialLines::pullAll(double t, double duration) {
  for (std::size_t i = 0; i < lines_.size(); ++i)
    pull(i, t, duration);
}

void SerialLines::reopenIfDue(Line& line, double t) {
  if (line.pty || line.reopen_at < 0.0 || t < line.reopen_at) return;
  try {
    line.pty = std::make_unique<PseudoTerminal>(line.link_path);
    line.firmware->lineReset();
    line.reopen_at = -1.0;
    spdlog::info("robot {}: serial line back at {}", line.robot_id, line.pty->slavePath());
  } catch (const std::exception& e) {
    errors_.push_back(e.what());
    line.reopen_at = t + kReopenRetry;
  }
}

void SerialLines::exchangeBytes(Line& line, double t) {
  if (!line.pty) {
    // Frames of a pulled line are lost with it.
    line.outgoing.clear();
    return;
  }
  in_.clear();
  out_.clear();
  if (line.pty->read(in_) > 0) line.firmware->receive(in_, t, out_);
  if (!out_.empty()) line.bytes_dropped += line.pty->write(out_);
  while (!line.outgoing.empty() && line.outgoing.front().first <= t) {
    line.bytes_dropped += line.pty->write(line.outgoing.front().second);
    line.outgoing.pop_front();
  }
}

void SerialLines::resumeAt(double t) {
  for (Line& line : lines_)
    line.next_sample = t;
  while (next_outage_ < outages_.size() && outages_[next_outage_].time < t)
    ++next_outage_;
}

void SerialLines::beforeStep(World& world) {
  const double t = world.time();
  while (next_outage_ < outages_.size() && outages_[next_outage_].time <= t) {
    const int index = world.indexOf(outages_[next_outage_].robot);
    if (index >= 0) pull(static_cast<std::size_t>(index), t, outages_[next_outage_].duration);
    ++next_outage_;
  }
  for (std::size_t i = 0; i < lines_.size(); ++i) {
    reopenIfDue(lines_[i], t);
    exchangeBytes(lines_[i], t);
    world.setCommand(i, lines_[i].firmware->motorCommand(t));
  }
}

void SerialLines::afterStep(const World& world) {
  const double t = world.time();
  for (std::size_t i = 0; i < lines_.size(); ++i) {
    auto& line = lines_[i];
    // The controller's gyro samples the body's true rotation rate at every physics step.
    line.firmware->gyroStep(world.robots()[i].omega, world.stepSeconds());
    if (t + 1e-9 < line.next_sample) continue;
    line.next_sample += sample_period_;
    std::vector<std::uint8_t> frame;
    const RobotTruth& truth = world.robots()[i];
    const WheelState wheels{truth.wheel_speeds, truth.wheel_slip};
    line.firmware->sample(t, world.ticks(i), frame, &wheels);
    line.outgoing.emplace_back(t + controller_latency_, std::move(frame));
  }
}

}  // namespace fieldline::world_sim
