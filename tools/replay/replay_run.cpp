#include "tools/replay/replay_run.hpp"

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

std::vector<std::string> inputChannels(const std::string& node) {
  if (node == "region_tracking") return {std::string(ch::kCameraImage.name)};
  if (node == "feature_recognition") return {std::string(ch::kVisionLines.name)};
  if (node == "fusion") {
    return {std::string(ch::kOdometry.name),        std::string(ch::kVisionLines.name),
            std::string(ch::kFieldFeatures.name),   std::string(ch::kVisionBall.name),
            std::string(ch::kVisionObstacles.name), std::string(ch::kTeamState.name)};
  }
  throw ReplayArgumentError("unknown node '" + node + "'");
}

std::vector<std::string> outputChannels(const std::string& node) {
  if (node == "region_tracking") {
    return {std::string(ch::kVisionLines.name), std::string(ch::kVisionBall.name),
            std::string(ch::kVisionObstacles.name)};
  }
  if (node == "feature_recognition") return {std::string(ch::kFieldFeatures.name)};
  if (node == "fusion")
    return {std::string(ch::kRobotState.name), std::string(ch::kBallState.name)};
  throw ReplayArgumentError("unknown node '" + node + "'");
}

std::vector<std::string> parseRunList(const std::string& text) {
  std::vector<std::string> names;
  std::stringstream in(text);
  std::string name;
  while (std::getline(in, name, ',')) {
    if (std::find(kRunnableNodes.begin(), kRunnableNodes.end(), name) == kRunnableNodes.end()) {
      throw ReplayArgumentError("unknown node '" + name +
                                "' (region_tracking, feature_recognition, fusion)");
    }
    if (std::find(names.begin(), names.end(), name) != names.end()) {
      throw ReplayArgumentError("node '" + name + "' named twice");
    }
    names.push_back(name);
  }
  if (names.empty()) throw ReplayArgumentError("no node to run");
  return names;
}

namespace {

template <typename Msg>
std::optional<int> firstRobotId(bus::LogReader& log, bus::Channel<Msg> channel) {
  log.rewind();
  Msg msg;
  if (log.next(channel, msg)) return msg.header.robot_id;
  return std::nullopt;
}

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

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The RECORDING_INFO of a replay's output: the robot and its clock, the field and the settings
// the nodes ran with, this build's version.
recording_info_t replayInfo(const ReplayRunOptions& options, const ReplayRunResult& result,
                            const std::string& field_file, const std::string& fusion_file) {
  recording_info_t info{};
  info.format_version = recording_info_t::FORMAT_VERSION;
  info.bus_robot_id = static_cast<std::int8_t>(result.robot_id);
  info.clock_model = result.clock.source == recording::ClockSource::kEstimated
                         ? recording_info_t::CLOCK_ESTIMATED
                     : result.clock.error.offset_us == 0 && result.clock.error.drift_ppm == 0.0
                         ? recording_info_t::CLOCK_NONE
                         : recording_info_t::CLOCK_CONFIGURED;
  info.clock_offset_us = result.clock.error.offset_us;
  info.clock_drift_ppm = result.clock.error.drift_ppm;
  info.clock_reference_us = result.clock.error.reference_us;
  info.host = "fieldline-replay";
  info.version = recording::buildVersion();
  info.field_name = result.field;
  info.field_yaml = readFile(config::resolvePreset("field", field_file));
  std::string run;
  for (const auto& name : options.run)
    run += (run.empty() ? "" : ", ") + name;
  info.settings_yaml = fmt::format("replay_of: {}\nrun: [{}]\nfusion_config_name: {}\n",
                                   options.log_path, run, result.fusion_config);
  if (std::find(options.run.begin(), options.run.end(), "fusion") != options.run.end()) {
    std::string text = readFile(config::resolvePreset("fusion", fusion_file));
    std::string indented;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);)
      indented += "  " + line + "\n";
    info.settings_yaml += "fusion_config: |\n" + indented;
  }
  info.header.robot_id = info.bus_robot_id;
  info.header.utime = result.clock.ownAt(firstLogTime(options.log_path));
  info.header.utime_published = info.header.utime;
  return info;
}

// Fixed per node kind: a random id would make two replays differ.
std::int64_t publisherId(const std::string& node) {
  const auto it = std::find(kRunnableNodes.begin(), kRunnableNodes.end(), node);
  return 0x7e9a1a0 + (it - kRunnableNodes.begin());
}

}  // namespace

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

namespace {

ReplayRunResult runReplayOfFile(const ReplayRunOptions& options);

}  // namespace

ReplayRunResult runReplay(const ReplayRunOptions& options) {
  if (!std::filesystem::is_directory(options.log_path)) return runReplayOfFile(options);
  // A recording's directory: the robot's files in order (robotN.lcm, robotN_part002.lcm, ...)
  // as one log, and the simulator's sim.lcm as the truth unless another is given.
  if (options.robot_id == 0) {
    throw ReplayArgumentError("a recording's directory needs the robot to replay (--robot N)");
  }
  const std::string name = "robot" + std::to_string(options.robot_id);
  std::vector<std::string> parts;
  for (const std::string& file : recording::recordingFiles(options.log_path)) {
    const std::string stem = std::filesystem::path(file).stem().string();
    if (stem == name || stem.rfind(name + "_part", 0) == 0) parts.push_back(file);
  }
  if (parts.empty()) {
    throw ReplayArgumentError("no " + name + ".lcm in " + options.log_path);
  }
  ReplayRunOptions one = options;
  one.log_path = parts.front();
  std::string joined;
  if (parts.size() > 1) {
    // LCM logs concatenate: the parts one after the other are one log.
    joined = (std::filesystem::temp_directory_path() /
              fmt::format("fieldline_replay_{}_{}.lcm", name, ::getpid()))
                 .string();
    std::ofstream out(joined, std::ios::binary);
    for (const std::string& part : parts)
      out << std::ifstream(part, std::ios::binary).rdbuf();
    one.log_path = joined;
  }
  const std::string sim = (std::filesystem::path(options.log_path) / "sim.lcm").string();
  if (one.truth_path.empty() && std::filesystem::exists(sim)) one.truth_path = sim;
  ReplayRunResult result;
  try {
    result = runReplayOfFile(one);
  } catch (...) {
    if (!joined.empty()) std::filesystem::remove(joined);
    throw;
  }
  if (!joined.empty()) std::filesystem::remove(joined);
  result.parts = static_cast<int>(parts.size());
  return result;
}

namespace {

ReplayRunResult runReplayOfFile(const ReplayRunOptions& options) {
  if (options.run.empty()) throw ReplayArgumentError("no node to run");
  for (const auto& name : options.run)
    inputChannels(name);  // names are known
  if (options.robot_id < 0 || options.robot_id > 6) {
    throw ReplayArgumentError("robot id must be 1..6 (0: from the log)");
  }

  ReplayRunResult result;
  result.robot_id = options.robot_id != 0 ? options.robot_id : detectRobotId(options.log_path);
  if (result.robot_id < 1 || result.robot_id > 6) {
    throw ReplayArgumentError("the log's robot id " + std::to_string(result.robot_id) +
                              " is not 1..6");
  }

  // What the recording says of itself (fieldline-record's RECORDING_INFO), if anything.
  const std::optional<recording_info_t> info = recording::readRecordingInfo(options.log_path);
  const bool info_fits = info && info->bus_robot_id == result.robot_id;

  // The robot's clock against the log's: given, else the recording's, else fitted to the log's
  // traffic.
  if (options.clock) {
    result.clock.error = *options.clock;
    result.clock.source = recording::ClockSource::kGiven;
    if (result.clock.error.reference_us == 0) {
      // A drift given without a reference counts from the log's first event.
      bus::LogReader first(options.log_path);
      bus::LogEvent event;
      if (first.nextEvent(event)) result.clock.error.reference_us = event.timestamp;
    }
  } else if (info_fits) {
    result.clock = recording::clockOf(*info);
  } else {
    const auto models = recording::estimateClocks(options.log_path);
    if (const auto it = models.find(result.robot_id); it != models.end()) result.clock = it->second;
  }
  result.clock.robot_id = result.robot_id;

  // Fed: what some run node reads, unless a run node produces it.
  std::vector<std::string> produced;
  std::vector<std::string> fed;
  for (const auto& name : options.run)
    for (auto& c : outputChannels(name))
      if (!contains(produced, c)) produced.push_back(std::move(c));
  for (const auto& name : options.run)
    for (auto& c : inputChannels(name))
      if (!contains(produced, c) && !contains(fed, c)) fed.push_back(std::move(c));

  SimulatedClock clock{0};
  auto memq = bus::Connection::open("memq://");
  auto makeNode = [&](const std::string& process) {
    return std::make_unique<bus::Node>(bus::NodeOptions{.process = process,
                                                        .robot_id = result.robot_id,
                                                        .status_period_us = 0,
                                                        .publisher_id = publisherId(process)},
                                       clock, memq);
  };

  // The settings: given, else the recording's (written to scratch files the loaders read), else
  // the processes' defaults.
  std::vector<std::string> scratch_files;
  const auto recorded = [&](const std::string& text, const std::string& what) {
    const std::string path =
        (std::filesystem::temp_directory_path() /
         fmt::format("fieldline_replay_{}_{}_{}.yaml", what, ::getpid(), scratch_files.size()))
            .string();
    std::ofstream(path) << text;
    scratch_files.push_back(path);
    return path;
  };
  std::string field_source = options.field;
  result.field = options.field;
  if (field_source.empty() && info_fits && !info->field_yaml.empty()) {
    field_source = recorded(info->field_yaml, "field");
    result.field = info->field_name + " (the recording's)";
  } else if (field_source.empty()) {
    field_source = result.field = "msl";
  }
  std::string fusion_source = options.fusion_config;
  result.fusion_config = options.fusion_config;
  const std::string recorded_fusion =
      info_fits ? recording::settingsValue(info->settings_yaml, "fusion_config") : std::string{};
  if (fusion_source.empty() && !recorded_fusion.empty()) {
    fusion_source = recorded(recorded_fusion, "fusion");
    result.fusion_config =
        recording::settingsValue(info->settings_yaml, "fusion_config_name") + " (the recording's)";
  } else if (fusion_source.empty()) {
    fusion_source = result.fusion_config = "default";
  }
  struct RemoveScratch {
    std::vector<std::string>& files;
    ~RemoveScratch() {
      for (const auto& f : files)
        std::filesystem::remove(f);
    }
  } remove_scratch{scratch_files};

  // The algorithms' state, created as the processes' main() create it.
  const field::FieldModel field = field::loadFieldPreset(field_source);
  std::unique_ptr<fusion::LineMatcher> matcher;
  std::vector<std::unique_ptr<bus::Node>> nodes;
  std::vector<std::string> node_names;
  std::unique_ptr<region_tracking::TrackingNode> tracking;
  std::unique_ptr<feature_recognition::FeatureNode> features;
  std::unique_ptr<fusion::FusionNode> fusion_node;

  for (const auto& name : kRunnableNodes) {
    if (!contains(options.run, name)) continue;
    nodes.push_back(makeNode(name));
    node_names.push_back(name);
    bus::Node& node = *nodes.back();
    if (name == "region_tracking") {
      region_tracking::TrackingNodeOptions tracking_options;
      const camera::CameraModel camera = camera::loadCameraPreset(options.camera);
      tracking_options.mirror = camera.mirror;
      tracking_options.colours = camera::loadColourTablePreset(camera.colour_table);
      // A measurement of this machine, not of the log: it would differ between replays.
      tracking_options.report_processing_time = false;
      tracking = std::make_unique<region_tracking::TrackingNode>(node, std::move(tracking_options));
    } else if (name == "feature_recognition") {
      features = std::make_unique<feature_recognition::FeatureNode>(node, field);
    } else {
      // As fieldline-fusion: the settings file, then the options that override it.
      fusion::FusionConfig config = fusion::loadFusionConfigPreset(fusion_source);
      if (options.matcher.empty()) {
        // the settings file's method
      } else if (options.matcher == "lsq") {
        config.matcher.method = fusion::MatchMethod::kRobustLeastSquares;
      } else if (options.matcher == "force_field") {
        config.matcher.method = fusion::MatchMethod::kForceField;
      } else {
        throw ReplayArgumentError("unknown matcher '" + options.matcher + "'");
      }
      if (options.start_prior != "own_half" && options.start_prior != "none") {
        throw ReplayArgumentError("unknown start prior '" + options.start_prior + "'");
      }
      matcher = std::make_unique<fusion::LineMatcher>(field, config.matcher, options.grid_cache);
      fusion::FusionNodeOptions fusion_options;
      fusion_options.robot = robot::loadRobotPreset(options.robot_config);
      fusion_options.localizer = config.localizer;
      fusion_options.ball = config.ball;
      fusion_options.team_ball_vote = config.team_ball_vote;
      fusion_options.ball_rate_hz = config.ball_rate_hz;
      fusion_options.localizer.start_prior = options.start_prior == "own_half"
                                                 ? fusion::StartPrior::kOwnHalf
                                                 : fusion::StartPrior::kNone;
      const geometry::Vec2 half = field.carpetHalfExtent();
      fusion_options.localizer.search_half_length_m = half.x();
      fusion_options.localizer.search_half_width_m = half.y();
      const fusion::LineMatcher& m = *matcher;
      const fusion::MatcherFunctions functions{
          [&m](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
            return m.correct(p, g);
          },
          [&m](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
            return m.cost(p, g);
          },
          [&m](std::span<const perception::LinePoint> p) {
            fusion::GlobalSearchParams search;
            search.max_results = 8;
            return m.globalSearch(p, search);
          }};
      fusion_node =
          std::make_unique<fusion::FusionNode>(node, std::move(fusion_options), functions);
    }
  }

  // Counts what crosses memq: fed channels are inputs, produced ones outputs.
  auto watcher = makeNode("replay_recorder");
  robot_state_t state;
  watcher->subscribeAllRaw([&](const std::string& channel, const void* data, int size) {
    if (contains(produced, channel)) {
      ++result.out[channel];
      if (channel == ch::kRobotState.name && state.decode(data, 0, size) == size &&
          state.status == robot_state_t::STATUS_TRACKING)
        ++result.tracking_states;
    } else if (contains(fed, channel)) {
      ++result.in[channel];
    }
  });
  std::unique_ptr<bus::LogWriter> writer;
  std::unique_ptr<bus::LogRecorder> recorder;
  // With a truth log the outputs go to a scratch file first, merged with SIM_WORLD at the end.
  const std::string replay_path = options.truth_path.empty() || options.out_path.empty()
                                      ? options.out_path
                                      : options.out_path + ".outputs";
  if (!options.out_path.empty()) {
    writer = std::make_unique<bus::LogWriter>(replay_path);
    // The output describes itself like a recording: whose, on which clock, run how.
    writer->write(ch::kRecordingInfo, firstLogTime(options.log_path),
                  replayInfo(options, result, field_source, fusion_source));
    recorder = std::make_unique<bus::LogRecorder>(
        *watcher, *writer, std::vector<std::string_view>(produced.begin(), produced.end()));
    // Written at the log's time, so the outputs line up with the recording (and its truth).
    recorder->setLogClock(result.clock.error);
  }

  std::string input_path = options.log_path;
  std::string oracle_path;
  if (options.oracle_contact) {
    if (options.truth_path.empty()) throw ReplayArgumentError("oracle_contact needs a truth log");
    if (!contains(options.run, "fusion")) throw ReplayArgumentError("oracle_contact needs fusion");
    oracle_path = (options.out_path.empty() ? options.log_path : options.out_path) + ".oracle";
    result.oracle_contacts =
        writeOracleContactLog(options, result.robot_id, result.clock.error, fed, oracle_path);
    input_path = oracle_path;
  }

  std::string stalled_path;
  if (options.stall_s > 0.0) {
    if (!(options.stall_every_s > options.stall_s) || options.stall_start_s < 0.0) {
      throw ReplayArgumentError("stalls need stall_every > stall_s > 0 and stall_start >= 0");
    }
    if (options.stall_hold.empty() && options.stall_drop.empty()) {
      throw ReplayArgumentError("stalls need channels to hold or drop");
    }
    stalled_path = (options.out_path.empty() ? options.log_path : options.out_path) + ".stalled";
    writeStalledLog(options, input_path, fed, stalled_path, result);
    input_path = stalled_path;
  }

  bus::Replay replay(clock, memq, {.channels = fed, .clock = result.clock.error});
  for (auto& node : nodes)
    replay.add(*node);
  replay.add(*watcher);
  bus::LogReader log(input_path, {.clock = result.clock.error});
  const bus::ReplayStats stats = replay.run(log);
  if (writer) writer->flush();
  if (!oracle_path.empty()) std::filesystem::remove(oracle_path);
  if (!stalled_path.empty()) std::filesystem::remove(stalled_path);

  result.skipped = stats.skipped;
  result.out_of_order = stats.out_of_order;
  result.rejected = log.rejectedByKind();
  result.upgraded = log.upgradedByKind();
  for (const bus::LogRejection& r : log.recentRejections()) {
    result.refusal_examples["reader/" + r.reason.kind] = fmt::format(
        "{}{}event {}: {}", r.channel, r.channel.empty() ? "" : " ", r.event_number, r.reason.text);
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    // Every error kind the node reported (refused inputs, the nodes' own checks).
    const service_status_t status = nodes[i]->status().takeStatus(clock.now());
    for (int e = 0; e < status.num_errors; ++e) {
      const auto k = static_cast<std::size_t>(e);
      const std::string kind = node_names[i] + "/" + status.error_kind[k];
      result.node_errors[kind] = status.error_count[k];
    }
    // A node keeps the text of its last error only.
    if (!status.last_error.empty())
      result.refusal_examples[node_names[i] + "/last"] = status.last_error;
  }
  if (watcher->status().errorCount("log_write") > 0) {
    throw bus::LogError("writing " + options.out_path + ": " + watcher->status().lastError());
  }
  const std::vector<std::string> truth_channels{std::string(ch::kSimWorld.name)};
  if (!options.truth_path.empty() && !options.out_path.empty()) {
    writer.reset();
    std::int64_t outputs = 1;  // the output's RECORDING_INFO
    for (const auto& [channel, count] : result.out)
      outputs += count;
    result.truth_merged =
        mergeLogs({{replay_path, {}}, {options.truth_path, truth_channels}}, options.out_path) -
        outputs;
    std::filesystem::remove(replay_path);
  }
  if (!options.live_out_path.empty()) {
    std::vector<MergeSource> sources{{options.log_path, produced}};
    if (!options.truth_path.empty()) sources.push_back({options.truth_path, truth_channels});
    result.live_written = mergeLogs(sources, options.live_out_path);
  }
  return result;
}

}  // namespace

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

std::int64_t ReplayRunResult::fedTotal() const {
  std::int64_t n = 0;
  for (const auto& [channel, count] : in)
    n += count;
  return n;
}

std::int64_t ReplayRunResult::refusedTotal() const {
  std::int64_t n = 0;
  for (const auto& [kind, count] : rejected)
    n += count;
  for (const auto& [kind, count] : node_errors)
    n += count;
  return n;
}

namespace {

double refusedShare(const ReplayRunResult& result) {
  // Events the reader refused never reached the nodes: they count among the inputs.
  std::int64_t reader = 0;
  for (const auto& [kind, count] : result.rejected)
    reader += count;
  const std::int64_t offered = result.fedTotal() + reader;
  return offered > 0 ? static_cast<double>(result.refusedTotal()) / static_cast<double>(offered)
                     : 0.0;
}

}  // namespace

std::string refusalReport(const ReplayRunResult& result) {
  const std::int64_t refused = result.refusedTotal();
  if (refused == 0) return {};
  std::int64_t reader = 0;
  for (const auto& [kind, count] : result.rejected)
    reader += count;
  std::string text = fmt::format("refused {} of {} inputs ({:.2f} %):", refused,
                                 result.fedTotal() + reader, 100.0 * refusedShare(result));
  const auto line = [&](const std::string& kind, std::int64_t count) {
    text += fmt::format("\n  {} {}", kind, count);
    const auto it = result.refusal_examples.find(kind);
    if (it != result.refusal_examples.end() && !it->second.empty()) text += ": " + it->second;
  };
  for (const auto& [kind, count] : result.rejected)
    line("reader/" + kind, count);
  for (const auto& [kind, count] : result.node_errors)
    line(kind, count);
  for (const auto& [kind, example] : result.refusal_examples) {
    if (kind.size() > 5 && kind.compare(kind.size() - 5, 5, "/last") == 0)
      text += fmt::format("\n  {} error: {}", kind.substr(0, kind.size() - 5), example);
  }
  return text;
}

std::vector<std::string> failures(const ReplayRunResult& result, const ReplayRunOptions& options) {
  std::vector<std::string> why;
  const double share = refusedShare(result);
  std::int64_t outputs = 0;
  for (const auto& [channel, count] : result.out)
    outputs += count;
  if (result.fedTotal() == 0) {
    why.push_back("no input reached the nodes (nothing in the log on the channels they read)");
  }
  if (share > options.max_refused_share) {
    why.push_back(
        fmt::format("{:.1f} % of the inputs were refused (at most {:.1f} % allowed; "
                    "see the kinds above)",
                    100.0 * share, 100.0 * options.max_refused_share));
  }
  if (std::find(options.run.begin(), options.run.end(), "fusion") != options.run.end()) {
    if (result.tracking_states == 0) {
      const auto it = result.out.find(std::string(ch::kRobotState.name));
      why.push_back(
          fmt::format("fusion published no valid estimate ({} ROBOT_STATE, none of "
                      "them tracking)",
                      it == result.out.end() ? 0 : it->second));
    }
  } else if (outputs == 0) {
    why.push_back("the nodes published nothing");
  }
  return why;
}

std::string summaryLine(const ReplayRunResult& result) {
  std::ostringstream line;
  line << "replay robot " << result.robot_id;
  if (result.parts > 1) line << " (" << result.parts << " files)";
  line << ": in";
  for (const auto& [channel, n] : result.in)
    line << ' ' << channel << ' ' << n;
  line << " | out";
  for (const auto& [channel, n] : result.out)
    line << ' ' << channel << ' ' << n;
  line << " | skipped " << result.skipped;
  std::int64_t rejected = 0;
  for (const auto& [kind, n] : result.rejected)
    rejected += n;
  line << " rejected " << rejected;
  std::int64_t refused = 0;
  for (const auto& [kind, n] : result.node_errors)
    refused += n;
  line << " refused " << refused << " out_of_order " << result.out_of_order;
  if (result.truth_merged > 0) line << " | SIM_WORLD merged " << result.truth_merged;
  if (result.live_written > 0) line << " | live events " << result.live_written;
  if (result.oracle_contacts > 0) line << " | oracle contacts " << result.oracle_contacts;
  if (result.stalls > 0) {
    line << " | stalls " << result.stalls << " held " << result.stall_held << " dropped "
         << result.stall_dropped;
  }
  if (result.out.count(std::string(ch::kRobotState.name)) > 0)
    line << " | tracking " << result.tracking_states;
  if (!result.upgraded.empty()) {
    line << " | upgraded";
    for (const auto& [name, n] : result.upgraded)
      line << ' ' << name << ' ' << n;
  }
  line << " | clock " << result.clock.describe() << " | field " << result.field;
  if (!result.fusion_config.empty()) line << ", fusion settings " << result.fusion_config;
  return line.str();
}

}  // namespace fieldline::replay
