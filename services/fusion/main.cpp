// fieldline-fusion: the localization process. Fuses ODOMETRY (layer 1), the line matcher's
// correction of every VISION_LINES frame (layer 2) and FIELD_FEATURES hypotheses (layer 3), each
// at the time it was observed, into ROBOT_STATE on every odometry message, and tracks the ball
// from VISION_BALL into BALL_STATE.
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include <cstdlib>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/robot/robot_params.hpp"
#include "services/fusion/fusion_config.hpp"
#include "services/fusion/fusion_node.hpp"
#include "services/fusion/line_matcher.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  CLI::App app{
      "Fusion: delay-aware pose estimation from ODOMETRY, VISION_LINES and FIELD_FEATURES "
      "(ROBOT_STATE on every odometry message) and ball tracking from VISION_BALL "
      "(BALL_STATE)."};
  bus::CommonOptions common;
  common.addTo(app);
  std::string field_preset = "msl";
  std::string robot_preset = "fu2004";
  std::string config_name = "default";
  std::string method = "lsq";
  std::string start_prior = "own_half";
  std::string cache_dir;
  double window_s = 1.0;
  double ball_rate = 30.0;
  double ball_max_age = 1.0;
  app.add_option("--field", field_preset, "Field preset (msl, fu2004) or YAML path")
      ->capture_default_str();
  app.add_option("--robot-config", robot_preset, "Robot preset name or YAML path")
      ->capture_default_str();
  app.add_option("--config", config_name,
                 "Fusion settings: preset name (config/fusion/NAME.yaml) or YAML path; the options "
                 "below override it where given")
      ->capture_default_str();
  app.add_option("--matcher", method, "Layer 2 method: lsq (robust least squares) or force_field")
      ->check(CLI::IsMember({"lsq", "force_field"}))
      ->capture_default_str();
  app.add_option("--start-prior", start_prior,
                 "Which symmetric twin to believe at start-up: own_half (x < 0) or none")
      ->check(CLI::IsMember({"own_half", "none"}))
      ->capture_default_str();
  app.add_option("--grid-cache", cache_dir,
                 "Directory for the distance grid cache (default: $XDG_CACHE_HOME/fieldline or "
                 "~/.cache/fieldline; empty string: none)");
  app.add_option("--window", window_s, "How far back a late measurement may reach, s")
      ->check(CLI::Range(0.1, 10.0))
      ->capture_default_str();
  app.add_option("--ball-rate", ball_rate, "BALL_STATE messages per second")
      ->check(CLI::Range(1.0, 200.0))
      ->capture_default_str();
  app.add_option("--ball-max-age", ball_max_age, "The ball is invalid after this long unseen, s")
      ->check(CLI::Range(0.05, 60.0))
      ->capture_default_str();
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("fusion", [&] {
    common.resolve("fusion");
    if (cache_dir.empty()) {
      if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
        cache_dir = std::string(xdg) + "/fieldline";
      } else if (const char* home = std::getenv("HOME"); home && *home) {
        cache_dir = std::string(home) + "/.cache/fieldline";
      }
    }
    const field::FieldModel field = field::loadFieldPreset(field_preset);
    fusion::FusionConfig config;
    config::runOrExit([&] { config = fusion::loadFusionConfigPreset(config_name); });
    if (app.count("--matcher") > 0) {
      config.matcher.method = method == "lsq" ? fusion::MatchMethod::kRobustLeastSquares
                                              : fusion::MatchMethod::kForceField;
    }
    if (common.check_args) {
      // The presets are read; the distance grid (seconds of CPU) is not built.
      (void)robot::loadRobotPreset(robot_preset);
      return 0;
    }
    const fusion::LineMatcher matcher(field, config.matcher, cache_dir);

    fusion::FusionNodeOptions options;
    options.robot = robot::loadRobotPreset(robot_preset);
    options.localizer = config.localizer;
    options.ball = config.ball;
    options.ball_rate_hz = config.ball_rate_hz;
    if (app.count("--window") > 0) {
      options.localizer.filter.window_us = static_cast<Utime>(window_s * 1e6);
    }
    if (app.count("--start-prior") > 0) {
      options.localizer.start_prior =
          start_prior == "own_half" ? fusion::StartPrior::kOwnHalf : fusion::StartPrior::kNone;
    }
    const geometry::Vec2 half = field.carpetHalfExtent();
    options.localizer.search_half_length_m = half.x();
    options.localizer.search_half_width_m = half.y();
    if (app.count("--ball-max-age") > 0) options.ball.max_age_s = ball_max_age;
    if (app.count("--ball-rate") > 0) options.ball_rate_hz = ball_rate;
    const fusion::MatcherFunctions functions{
        [&](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
          return matcher.correct(p, g);
        },
        [&](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
          return matcher.cost(p, g);
        },
        [&](std::span<const perception::LinePoint> p) {
          fusion::GlobalSearchParams search;
          search.max_results = 8;
          return matcher.globalSearch(p, search);
        }};

    const RobotClock clock = bus::robotClockFromEnvironment();
    bus::installStopSignals();
    bus::Node node({.process = "fusion", .robot_id = common.robot, .url = common.bus_url}, clock);
    fusion::FusionNode fusion(node, std::move(options), functions);
    spdlog::info("fusing on field {} with the {} matcher, settings {}", field_preset,
                 config.matcher.method == fusion::MatchMethod::kForceField ? "force_field" : "lsq",
                 config_name);
    return node.run();
  });
}
