// The logs a replay reads and writes besides the recording itself: see replay_logs.hpp.
#include "tools/replay/replay_logs.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <unistd.h>

#include <fieldline/obstacle_observations_t.hpp>
#include <fieldline/robot_state_t.hpp>
#include <fieldline/service_status_t.hpp>

#include "common/bus/channels.hpp"
#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/bus/replay.hpp"
#include "common/camera/colour.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/robot/robot_params.hpp"
#include "common/time/clock.hpp"
#include "services/feature_recognition/feature_node.hpp"
#include "services/fusion/fusion_config.hpp"
#include "services/fusion/fusion_node.hpp"
#include "services/fusion/line_matcher.hpp"
#include "services/region_tracking/tracking_node.hpp"
#include "tools/recording/recording_info.hpp"

namespace fieldline::replay {

namespace ch = bus::channels;

namespace {

template <typename Msg>
std::optional<int> firstRobotId(bus::LogReader& log, bus::Channel<Msg> channel) {
  log.rewind();
  Msg msg;
  if (log.next(channel, msg)) return msg.header.robot_id;
  return std::nullopt;
}

}  // namespace

int detectRobotId(const std::string& path) {
  // The recording says whose bus it is.
  if (const auto info = recording::readRecordingInfo(path);
      info && info->bus_robot_id >= 1 && info->bus_robot_id <= 6)
    return info->bus_robot_id;
  // A reader of its own: its rejection counts must not add to the replay's. The robot's clock is
  // not known yet: no future check.
  bus::LogReader log(path, {.future_tolerance_us = std::numeric_limits<Utime>::max() / 4});
  if (auto id = firstRobotId(log, ch::kOdometry)) return *id;
  if (auto id = firstRobotId(log, ch::kVisionLines)) return *id;
  if (auto id = firstRobotId(log, ch::kCameraImage)) return *id;
  throw ReplayArgumentError("no RECORDING_INFO, ODOMETRY, VISION_LINES or CAMERA_IMAGE in " + path +
                            " to take the robot id from; give --robot");
}

bool contains(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

// oracle_contact: writes `scratch` with the fed channels of `options.log_path` except
// VISION_OBSTACLES, and in their place one VISION_OBSTACLES frame (an obstacle at the body) at
// every SIM_WORLD sample of the truth log in which the robot touches another robot. Returns the
// number of such samples.
std::int64_t writeOracleContactLog(const ReplayRunOptions& options, int robot_id,
                                   const ClockError& clock, const std::vector<std::string>& fed,
                                   const std::string& scratch) {
  const std::string evidence_path = scratch + ".contacts";
  std::int64_t contacts = 0;
  {
    bus::LogReader truth(options.truth_path);
    bus::LogWriter out(evidence_path);
    world_state_t world;
    bus::LogEvent event;
    obstacle_observations_t m{};
    m.header.robot_id = static_cast<std::int8_t>(robot_id);
    m.header.publisher_id = 0x0c0ac1e;
    m.count = 1;
    m.bearing = {0.0f};
    m.distance = {0.0f};
    m.angular_width = {0.0f};
    m.width = {0.0f};
    m.x = {0.0f};
    m.y = {0.0f};
    while (truth.next(ch::kSimWorld, world, &event)) {
      if (!touchesAnotherRobot(world, robot_id)) continue;
      // The simulator's time is the log's; the evidence is stamped on the robot's clock.
      m.header.utime = truthToOwn(clock, world.header.utime);
      m.header.utime_published = truthToOwn(clock, std::max(world.header.utime, event.timestamp));
      m.header.seq = contacts++;
      out.write(ch::kVisionObstacles, event.timestamp, m);
    }
    out.flush();
  }
  std::vector<std::string> kept;
  for (const auto& c : fed)
    if (c != ch::kVisionObstacles.name) kept.push_back(c);
  mergeLogs({{options.log_path, kept}, {evidence_path, {}}}, scratch);
  std::filesystem::remove(evidence_path);
  return contacts;
}

// stall_s: writes `scratch` with the fed channels of `input` as a starved process receives them
// (ReplayRunOptions::stall_hold, stall_drop), in log-time order.
void writeStalledLog(const ReplayRunOptions& options, const std::string& input,
                     const std::vector<std::string>& fed, const std::string& scratch,
                     ReplayRunResult& result) {
  bus::LogReader in(input);
  bus::LogWriter out(scratch);
  StallSchedule schedule{.every_s = options.stall_every_s,
                         .start_s = options.stall_start_s,
                         .length_s = options.stall_s};
  bus::LogEvent e;
  bool have_first = false;
  std::int64_t last_stall = -1;
  std::vector<bus::LogEvent> held;
  Utime held_until = 0;
  const auto flush = [&] {
    for (const auto& h : held)
      out.write(h.channel, held_until, h.data.data(), static_cast<int>(h.data.size()));
    held.clear();
  };
  while (in.nextEvent(e)) {
    if (!contains(fed, e.channel)) continue;
    if (!have_first) {
      schedule.first = e.timestamp;
      have_first = true;
    }
    if (!held.empty() && e.timestamp >= held_until) flush();
    const std::int64_t stall = schedule.stallAt(e.timestamp);
    if (stall >= 0 && stall != last_stall) {
      ++result.stalls;
      last_stall = stall;
    }
    if (stall >= 0 && contains(options.stall_drop, e.channel)) {
      ++result.stall_dropped;
      continue;
    }
    if (stall >= 0 && contains(options.stall_hold, e.channel)) {
      ++result.stall_held;
      held_until = schedule.stallEnd(stall);
      held.push_back(e);
      continue;
    }
    out.write(e.channel, e.timestamp, e.data.data(), static_cast<int>(e.data.size()));
  }
  flush();
  out.flush();
}

// The log time of the log's first event (0 for an empty log).
Utime firstLogTime(const std::string& path) {
  bus::LogReader log(path);
  bus::LogEvent event;
  return log.nextEvent(event) ? event.timestamp : 0;
}

std::int64_t StallSchedule::stallAt(Utime t) const {
  if (!(length_s > 0.0) || !(every_s > 0.0)) return -1;
  const double since = static_cast<double>(t - first) * 1e-6 - start_s;
  if (since < 0.0) return -1;
  const auto k = static_cast<std::int64_t>(std::floor(since / every_s));
  return since - static_cast<double>(k) * every_s < length_s ? k : -1;
}

Utime StallSchedule::stallEnd(std::int64_t k) const {
  return first + static_cast<Utime>(
                     std::llround((start_s + static_cast<double>(k) * every_s + length_s) * 1e6));
}

bool touchesAnotherRobot(const world_state_t& world, int robot_id) {
  const auto n = static_cast<std::size_t>(std::max(0, world.num_robots));
  std::size_t k = 0;
  while (k < n && world.robot_id[k] != robot_id)
    ++k;
  if (k == n) return false;
  // The simulator resolves a collision by moving the bodies apart until they just touch, so a
  // touching pair is at the two radii (to rounding) in SIM_WORLD: 1 cm of margin.
  constexpr double kMargin = 0.01;
  const double r = world.robot_radius;
  const double x = world.robot_x[k];
  const double y = world.robot_y[k];
  for (std::size_t j = 0; j < n; ++j) {
    if (j != k && std::hypot(world.robot_x[j] - x, world.robot_y[j] - y) < 2.0 * r + kMargin)
      return true;
  }
  for (std::size_t j = 0; j < static_cast<std::size_t>(std::max(0, world.num_opponents)); ++j) {
    if (std::hypot(world.opponent_x[j] - x, world.opponent_y[j] - y) <
        r + world.opponent_radius[j] + kMargin)
      return true;
  }
  return false;
}

std::int64_t mergeLogs(const std::vector<MergeSource>& sources, const std::string& out_path) {
  struct Cursor {
    std::unique_ptr<bus::LogReader> reader;
    const std::vector<std::string>* channels;
    bus::LogEvent event;
    bool valid = false;
    void advance() {
      valid = false;
      while (reader->nextEvent(event)) {
        if (!channels->empty() && !contains(*channels, event.channel)) continue;
        if (!reader->accept(event)) continue;
        valid = true;
        return;
      }
    }
  };
  std::vector<Cursor> cursors;
  for (const auto& source : sources) {
    cursors.push_back({std::make_unique<bus::LogReader>(source.path), &source.channels, {}});
    cursors.back().advance();
  }
  bus::LogWriter out(out_path);
  while (true) {
    Cursor* first = nullptr;
    for (auto& c : cursors)
      if (c.valid && (!first || c.event.timestamp < first->event.timestamp)) first = &c;
    if (!first) break;
    out.write(first->event.channel, first->event.timestamp, first->event.data.data(),
              static_cast<int>(first->event.data.size()));
    first->advance();
  }
  out.flush();
  return out.eventsWritten();
}

}  // namespace fieldline::replay
