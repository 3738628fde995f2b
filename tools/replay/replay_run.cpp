// fieldline-replay's run: the nodes of a recording replayed in one process over memq, their
// inputs fed from the log, their outputs counted and written (the logs it reads and writes
// besides: replay_logs.cpp; its report: replay_report.cpp).
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
#include "tools/replay/replay_logs.hpp"

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

// Fixed per node kind: a random id would make two replays differ.
std::int64_t publisherId(const std::string& node) {
  const auto it = std::find(kRunnableNodes.begin(), kRunnableNodes.end(), node);
  return 0x7e9a1a0 + (it - kRunnableNodes.begin());
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

// The channels of the run nodes: fed (what some run node reads, unless a run node produces it)
// and produced.
struct RunChannels {
  std::vector<std::string> fed;
  std::vector<std::string> produced;
};

RunChannels runChannels(const std::vector<std::string>& run) {
  RunChannels c;
  for (const auto& name : run)
    for (auto& channel : outputChannels(name))
      if (!contains(c.produced, channel)) c.produced.push_back(std::move(channel));
  for (const auto& name : run)
    for (auto& channel : inputChannels(name))
      if (!contains(c.produced, channel) && !contains(c.fed, channel))
        c.fed.push_back(std::move(channel));
  return c;
}

// The robot's clock against the log's: given, else the recording's, else fitted to the log's
// traffic.
void resolveClock(const ReplayRunOptions& options, const std::optional<recording_info_t>& info,
                  bool info_fits, ReplayRunResult& result) {
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
}

// The settings: given, else the recording's (written to scratch files the loaders read, removed
// with this object), else the processes' defaults.
class SettingsFiles {
 public:
  SettingsFiles(const ReplayRunOptions& options, const std::optional<recording_info_t>& info,
                bool info_fits, ReplayRunResult& result) {
    field_source = options.field;
    result.field = options.field;
    if (field_source.empty() && info_fits && !info->field_yaml.empty()) {
      field_source = scratch(info->field_yaml, "field");
      result.field = info->field_name + " (the recording's)";
    } else if (field_source.empty()) {
      field_source = result.field = "msl";
    }
    fusion_source = options.fusion_config;
    result.fusion_config = options.fusion_config;
    const std::string recorded_fusion =
        info_fits ? recording::settingsValue(info->settings_yaml, "fusion_config") : std::string{};
    if (fusion_source.empty() && !recorded_fusion.empty()) {
      fusion_source = scratch(recorded_fusion, "fusion");
      result.fusion_config = recording::settingsValue(info->settings_yaml, "fusion_config_name") +
                             " (the recording's)";
    } else if (fusion_source.empty()) {
      fusion_source = result.fusion_config = "default";
    }
  }
  SettingsFiles(const SettingsFiles&) = delete;
  SettingsFiles& operator=(const SettingsFiles&) = delete;
  ~SettingsFiles() {
    for (const auto& f : files_)
      std::filesystem::remove(f);
  }

  std::string field_source;
  std::string fusion_source;

 private:
  std::string scratch(const std::string& text, const std::string& what) {
    const std::string path =
        (std::filesystem::temp_directory_path() /
         fmt::format("fieldline_replay_{}_{}_{}.yaml", what, ::getpid(), files_.size()))
            .string();
    std::ofstream(path) << text;
    files_.push_back(path);
    return path;
  }

  std::vector<std::string> files_;
};

// The algorithm nodes of the run, created as the processes' main() create them.
struct Processes {
  std::unique_ptr<fusion::LineMatcher> matcher;
  std::vector<std::unique_ptr<bus::Node>> nodes;
  std::vector<std::string> node_names;
  std::unique_ptr<region_tracking::TrackingNode> tracking;
  std::unique_ptr<feature_recognition::FeatureNode> features;
  std::unique_ptr<fusion::FusionNode> fusion_node;
};

std::unique_ptr<region_tracking::TrackingNode> makeTrackingNode(bus::Node& node,
                                                                const std::string& camera_preset) {
  region_tracking::TrackingNodeOptions tracking_options;
  const camera::CameraModel camera = camera::loadCameraPreset(camera_preset);
  tracking_options.mirror = camera.mirror;
  tracking_options.colours = camera::loadColourTablePreset(camera.colour_table);
  // A measurement of this machine, not of the log: it would differ between replays.
  tracking_options.report_processing_time = false;
  return std::make_unique<region_tracking::TrackingNode>(node, std::move(tracking_options));
}

// As fieldline-fusion: the settings file, then the options that override it.
void makeFusionNode(bus::Node& node, const ReplayRunOptions& options,
                    const field::FieldModel& field, const std::string& fusion_source,
                    Processes& p) {
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
  p.matcher = std::make_unique<fusion::LineMatcher>(field, config.matcher, options.grid_cache);
  fusion::FusionNodeOptions fusion_options;
  fusion_options.robot = robot::loadRobotPreset(options.robot_config);
  fusion_options.localizer = config.localizer;
  fusion_options.ball = config.ball;
  fusion_options.team_ball_vote = config.team_ball_vote;
  fusion_options.ball_rate_hz = config.ball_rate_hz;
  fusion_options.localizer.start_prior =
      options.start_prior == "own_half" ? fusion::StartPrior::kOwnHalf : fusion::StartPrior::kNone;
  const geometry::Vec2 half = field.carpetHalfExtent();
  fusion_options.localizer.search_half_length_m = half.x();
  fusion_options.localizer.search_half_width_m = half.y();
  const fusion::LineMatcher& m = *p.matcher;
  const fusion::MatcherFunctions functions{
      [&m](std::span<const perception::LinePoint> points, const geometry::Pose2& guess) {
        return m.correct(points, guess);
      },
      [&m](std::span<const perception::LinePoint> points, const geometry::Pose2& guess) {
        return m.cost(points, guess);
      },
      [&m](std::span<const perception::LinePoint> points) {
        fusion::GlobalSearchParams search;
        search.max_results = 8;
        return m.globalSearch(points, search);
      }};
  p.fusion_node = std::make_unique<fusion::FusionNode>(node, std::move(fusion_options), functions);
}

template <typename MakeNode>
void createProcesses(const ReplayRunOptions& options, const field::FieldModel& field,
                     const std::string& fusion_source, MakeNode makeNode, Processes& p) {
  for (const auto& name : kRunnableNodes) {
    if (!contains(options.run, name)) continue;
    p.nodes.push_back(makeNode(name));
    p.node_names.push_back(name);
    bus::Node& node = *p.nodes.back();
    if (name == "region_tracking") {
      p.tracking = makeTrackingNode(node, options.camera);
    } else if (name == "feature_recognition") {
      p.features = std::make_unique<feature_recognition::FeatureNode>(node, field);
    } else {
      makeFusionNode(node, options, field, fusion_source, p);
    }
  }
}

// The log the replay reads: the recording, or a scratch copy with oracle contacts or stalls
// (removed by the caller once the replay ran).
struct ReplayInput {
  std::string path;
  std::string oracle_path;
  std::string stalled_path;
};

ReplayInput prepareInput(const ReplayRunOptions& options, const std::vector<std::string>& fed,
                         ReplayRunResult& result) {
  ReplayInput input{options.log_path, {}, {}};
  if (options.oracle_contact) {
    if (options.truth_path.empty()) throw ReplayArgumentError("oracle_contact needs a truth log");
    if (!contains(options.run, "fusion")) throw ReplayArgumentError("oracle_contact needs fusion");
    input.oracle_path =
        (options.out_path.empty() ? options.log_path : options.out_path) + ".oracle";
    result.oracle_contacts =
        writeOracleContactLog(options, result.robot_id, result.clock.error, fed, input.oracle_path);
    input.path = input.oracle_path;
  }
  if (options.stall_s > 0.0) {
    if (!(options.stall_every_s > options.stall_s) || options.stall_start_s < 0.0) {
      throw ReplayArgumentError("stalls need stall_every > stall_s > 0 and stall_start >= 0");
    }
    if (options.stall_hold.empty() && options.stall_drop.empty()) {
      throw ReplayArgumentError("stalls need channels to hold or drop");
    }
    input.stalled_path =
        (options.out_path.empty() ? options.log_path : options.out_path) + ".stalled";
    writeStalledLog(options, input.path, fed, input.stalled_path, result);
    input.path = input.stalled_path;
  }
  return input;
}

// What the replay and its reader counted, and every error kind the nodes reported (refused
// inputs, the nodes' own checks).
void collectCounts(const bus::ReplayStats& stats, const bus::LogReader& log, const Processes& p,
                   Utime now, ReplayRunResult& result) {
  result.skipped = stats.skipped;
  result.out_of_order = stats.out_of_order;
  result.rejected = log.rejectedByKind();
  result.upgraded = log.upgradedByKind();
  for (const bus::LogRejection& r : log.recentRejections()) {
    result.refusal_examples["reader/" + r.reason.kind] = fmt::format(
        "{}{}event {}: {}", r.channel, r.channel.empty() ? "" : " ", r.event_number, r.reason.text);
  }
  for (std::size_t i = 0; i < p.nodes.size(); ++i) {
    const service_status_t status = p.nodes[i]->status().takeStatus(now);
    for (int e = 0; e < status.num_errors; ++e) {
      const auto k = static_cast<std::size_t>(e);
      const std::string kind = p.node_names[i] + "/" + status.error_kind[k];
      result.node_errors[kind] = status.error_count[k];
    }
    // A node keeps the text of its last error only.
    if (!status.last_error.empty())
      result.refusal_examples[p.node_names[i] + "/last"] = status.last_error;
  }
}

// The robot to replay (given, else the log's), after checking the nodes and the id.
int robotToReplay(const ReplayRunOptions& options) {
  if (options.run.empty()) throw ReplayArgumentError("no node to run");
  for (const auto& name : options.run)
    inputChannels(name);  // names are known
  if (options.robot_id < 0 || options.robot_id > 6) {
    throw ReplayArgumentError("robot id must be 1..6 (0: from the log)");
  }
  const int robot_id = options.robot_id != 0 ? options.robot_id : detectRobotId(options.log_path);
  if (robot_id < 1 || robot_id > 6) {
    throw ReplayArgumentError("the log's robot id " + std::to_string(robot_id) + " is not 1..6");
  }
  return robot_id;
}

// The outputs (written to `replay_path`) merged with the truth log's SIM_WORLD into
// options.out_path, and the live outputs of the recording merged into options.live_out_path.
void mergeOutputs(const ReplayRunOptions& options, const std::string& replay_path,
                  const std::vector<std::string>& produced, ReplayRunResult& result) {
  const std::vector<std::string> truth_channels{std::string(ch::kSimWorld.name)};
  if (!options.truth_path.empty() && !options.out_path.empty()) {
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
}

ReplayRunResult runReplayOfFile(const ReplayRunOptions& options) {
  ReplayRunResult result;
  result.robot_id = robotToReplay(options);
  // What the recording says of itself (fieldline-record's RECORDING_INFO), if anything.
  const std::optional<recording_info_t> info = recording::readRecordingInfo(options.log_path);
  const bool info_fits = info && info->bus_robot_id == result.robot_id;
  resolveClock(options, info, info_fits, result);
  const RunChannels channels = runChannels(options.run);
  const std::vector<std::string>& produced = channels.produced;
  const std::vector<std::string>& fed = channels.fed;

  SimulatedClock clock{0};
  auto memq = bus::Connection::open("memq://");
  auto makeNode = [&](const std::string& process) {
    return std::make_unique<bus::Node>(bus::NodeOptions{.process = process,
                                                        .robot_id = result.robot_id,
                                                        .status_period_us = 0,
                                                        .publisher_id = publisherId(process)},
                                       clock, memq);
  };
  const SettingsFiles settings(options, info, info_fits, result);
  const field::FieldModel field = field::loadFieldPreset(settings.field_source);
  Processes processes;
  createProcesses(options, field, settings.fusion_source, makeNode, processes);

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
                  replayInfo(options, result, settings.field_source, settings.fusion_source));
    recorder = std::make_unique<bus::LogRecorder>(
        *watcher, *writer, std::vector<std::string_view>(produced.begin(), produced.end()));
    // Written at the log's time, so the outputs line up with the recording (and its truth).
    recorder->setLogClock(result.clock.error);
  }
  const ReplayInput input = prepareInput(options, fed, result);

  bus::Replay replay(clock, memq, {.channels = fed, .clock = result.clock.error});
  for (auto& node : processes.nodes)
    replay.add(*node);
  replay.add(*watcher);
  bus::LogReader log(input.path, {.clock = result.clock.error});
  const bus::ReplayStats stats = replay.run(log);
  if (writer) writer->flush();
  if (!input.oracle_path.empty()) std::filesystem::remove(input.oracle_path);
  if (!input.stalled_path.empty()) std::filesystem::remove(input.stalled_path);
  collectCounts(stats, log, processes, clock.now(), result);
  if (watcher->status().errorCount("log_write") > 0) {
    throw bus::LogError("writing " + options.out_path + ": " + watcher->status().lastError());
  }
  if (!options.truth_path.empty() && !options.out_path.empty()) writer.reset();
  mergeOutputs(options, replay_path, produced, result);
  return result;
}

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

}  // namespace fieldline::replay
