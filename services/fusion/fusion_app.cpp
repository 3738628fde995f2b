#include "services/fusion/fusion_app.hpp"
#include "common/process/supervisor_identity.hpp"

#include <time.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <utility>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"

#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/robot/robot_params.hpp"
#include "services/fusion/fusion_config.hpp"
#include "services/fusion/fusion_node.hpp"
#include "services/fusion/line_matcher.hpp"

namespace fieldline::fusion {

namespace {

template <typename T>
cli::Option* addOverride(cli::App& app, const std::string& name, std::optional<T>& target,
                         const std::string& help) {
  return app.add_option(name, target, help);
}

// The settings file with the command line's overrides applied.
FusionConfig resolveConfig(const FusionAppOptions& options, const field::FieldModel& field) {
  FusionConfig config = loadFusionConfigPreset(options.config);
  if (options.matcher) {
    config.matcher.method =
        *options.matcher == "lsq" ? MatchMethod::kRobustLeastSquares : MatchMethod::kForceField;
  }
  if (options.start_prior) {
    config.localizer.start_prior =
        *options.start_prior == "own_half" ? StartPrior::kOwnHalf : StartPrior::kNone;
  }
  if (options.window_s) {
    config.localizer.filter.window_us = static_cast<Utime>(*options.window_s * 1e6);
  }
  if (options.ball_max_age_s) config.ball.max_age_s = *options.ball_max_age_s;
  if (options.ball_rate_hz) config.ball_rate_hz = *options.ball_rate_hz;
  const geometry::Vec2 half = field.carpetHalfExtent();
  config.localizer.search_half_length_m = half.x();
  config.localizer.search_half_width_m = half.y();
  return config;
}

// CLOCK_BOOTTIME, us: a step of the wall clock (NTP, the eval's clockstep fault) does not move it.
Utime steadyNowUs() {
  timespec ts{};
  ::clock_gettime(CLOCK_BOOTTIME, &ts);
  return static_cast<Utime>(ts.tv_sec) * 1'000'000 + ts.tv_nsec / 1000;
}

// The pose memory's options, its file's folder made; none (with a warning) when it cannot be.
PoseMemoryOptions poseMemory(const FusionAppOptions& options, int robot_id) {
  PoseMemoryOptions memory;
  std::string path = options.state_file;
  if (path.empty()) return memory;
  if (path == "default") path = "/tmp/fieldline/fusion" + std::to_string(robot_id) + ".pose";
  std::error_code ec;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  if (!folder.empty()) std::filesystem::create_directories(folder, ec);
  if (ec) {
    spdlog::warn("no pose memory across restarts: cannot make {}: {}", folder.string(),
                 ec.message());
    return memory;
  }
  memory.path = path;
  memory.fresh = options.fresh;
  memory.field = options.field;
  memory.supervisor = process::supervisorIdentity();
  memory.steady_now = steadyNowUs;
  return memory;
}

}  // namespace

void FusionAppOptions::addTo(cli::App& app) {
  grid_cache = config::defaultCacheDirectory();
  state_file = "default";
  app.add_option("--field", field, "Field preset (msl, fu2004) or YAML path")
      ->capture_default_str();
  app.add_option("--robot-config", robot, "Robot preset name or YAML path")->capture_default_str();
  app.add_option(
         "--config", config,
         "Fusion settings: preset name (config/fusion/NAME.yaml), YAML path or none (the code's "
         "defaults); the options "
         "below override it where given")
      ->capture_default_str();
  app.add_option("--grid-cache", grid_cache,
                 "Directory for the distance grid cache (empty string: none)")
      ->capture_default_str();
  app.add_option("--state-file", state_file,
                 "The pose saved every 0.2 s while TRACKING and when fusion stops; fusion "
                 "restarted by the same supervisor (the launcher, systemd) within "
                 "localizer.resume_max_age_s takes it as the twin's reference (`default`: "
                 "/tmp/fieldline/fusion<N>.pose; empty string: none)")
      ->capture_default_str();
  app.add_flag("--fresh", fresh,
               "Start up without reading the saved pose (the own-half prior decides the twin)");
  addOverride(app, "--matcher", matcher,
              "Layer 2 method: lsq (robust least squares) or force_field")
      ->check(cli::IsMember({"lsq", "force_field"}));
  addOverride(app, "--start-prior", start_prior,
              "Which symmetric twin to believe at start-up: own_half (x < 0) or none")
      ->check(cli::IsMember({"own_half", "none"}));
  addOverride(app, "--window", window_s, "How far back a late measurement may reach, s")
      ->check(cli::Range(0.1, 10.0));
  addOverride(app, "--ball-rate", ball_rate_hz, "BALL_STATE messages per second")
      ->check(cli::Range(1.0, 200.0));
  addOverride(app, "--ball-max-age", ball_max_age_s,
              "The ball is invalid after this long unseen, s")
      ->check(cli::Range(0.05, 60.0));
  app.add_flag("--print-config", print_config,
               "Print the settings in effect (--config and the options above) as YAML and exit");
  app.add_flag("--print-settings-table", print_settings_table,
               "Print every setting's key, default, unit, range and why as Markdown and exit");
}

int runFusion(const FusionAppOptions& options, const bus::CommonOptions& common) {
  const field::FieldModel field = field::loadFieldPreset(options.field);
  const FusionConfig config = resolveConfig(options, field);
  if (options.print_settings_table) {
    std::cout << fusionSettingsMarkdown();
    return 0;
  }
  if (options.print_config) {
    std::cout << fusionConfigYaml(config);
    return 0;
  }
  const robot::RobotParams robot = robot::loadRobotPreset(options.robot);
  if (common.print_io) return bus::printIo(fusionIo());
  if (common.check_args) return 0;

  const LineMatcher matcher(field, config.matcher, options.grid_cache);
  FusionNodeOptions node_options;
  node_options.robot = robot;
  node_options.localizer = config.localizer;
  node_options.ball = config.ball;
  node_options.team_ball_vote = config.team_ball_vote;
  node_options.ball_rate_hz = config.ball_rate_hz;
  node_options.pose_memory = poseMemory(options, common.robot);
  const MatcherFunctions functions{[&](std::span<const perception::LinePoint> p,
                                       const geometry::Pose2& g) { return matcher.correct(p, g); },
                                   [&](std::span<const perception::LinePoint> p,
                                       const geometry::Pose2& g) { return matcher.cost(p, g); },
                                   [&](std::span<const perception::LinePoint> p) {
                                     GlobalSearchParams search;
                                     search.max_results = 8;
                                     return matcher.globalSearch(p, search);
                                   }};

  bus::installStopSignals();
  // The node keeps a reference to its clock: it must outlive the node (a temporary here was a
  // dangling reference, and fusion crashed within 2 s of its start).
  const RobotClock clock = bus::robotClockFromEnvironment();
  bus::Node node({.process = "fusion", .robot_id = common.robot, .url = common.bus_url}, clock);
  const std::string memory_path = node_options.pose_memory.path;
  FusionNode fusion(node, std::move(node_options), functions);
  spdlog::info("fusing on field {} with the {} matcher, settings {}; pose memory: {}",
               options.field,
               config.matcher.method == MatchMethod::kForceField ? "force_field" : "lsq",
               options.config, memory_path.empty() ? std::string("none") : memory_path);
  return node.run();
}

}  // namespace fieldline::fusion
