// fieldline-time-shift: the delay between odometry and vision in a recorded log (seed 4.7.2).
// Turn the robot back and forth next to a ball lying still while recording its bus
// (lcm-logger); this correlates odometry's rotation rate with the rate at which the ball's
// bearing turns, prints the shift of vision's stamps against odometry's, and the latencies the
// configuration assumes. With correct latencies the shift is zero; otherwise add it to the
// camera's configured latency.
#include <cstdio>
#include <filesystem>
#include <limits>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/robot/robot_params.hpp"
#include "services/fusion/time_shift.hpp"

using namespace fieldline;

namespace {

struct Samples {
  std::vector<fusion::RateSample> odometry;
  std::vector<fusion::BallBearing> ball;
};

// Odometry's rotation rates and the ball's sightings, in stamp order, from the whole log.
Samples readLog(const std::string& log) {
  SystemClock clock;
  bus::Node node({.process = "time_shift",
                  .robot_id = 0,
                  .url = "file://" + std::filesystem::absolute(log).string() + "?speed=0",
                  .future_tolerance_us = std::numeric_limits<Utime>::max() / 4,
                  .status_period_us = 0},
                 clock);
  Samples s;
  node.subscribe(bus::channels::kOdometry, [&](const odometry_t& m) {
    if (s.odometry.empty() || m.header.utime > s.odometry.back().utime)
      s.odometry.push_back({m.header.utime, m.omega});
  });
  node.subscribe(bus::channels::kVisionBall, [&](const ball_observation_t& m) {
    if (m.visible && (s.ball.empty() || m.header.utime > s.ball.back().utime))
      s.ball.push_back({m.header.utime, m.x, m.y});
  });
  int idle_ms = 0;
  while (idle_ms < 1000) {
    idle_ms = node.spinOnce(100) > 0 ? 0 : idle_ms + 100;
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Estimates the delay between odometry and vision from a recorded LCM log (ODOMETRY and "
      "VISION_BALL of one robot, the robot turning next to a ball lying still) by correlating "
      "their rotation rates, and prints it next to the configured latencies."};
  std::string log;
  std::string camera = "omni_sim";
  std::string robot = "fu2004";
  double max_shift_ms = 300.0;
  app.add_option("LOG", log, "LCM log file")->required()->check(cli::ExistingFile);
  app.add_option("--camera", camera, "Camera preset whose pipeline latency is configured")
      ->capture_default_str();
  app.add_option("--robot-config", robot, "Robot preset whose controller latency is configured")
      ->capture_default_str();
  app.add_option("--max-shift", max_shift_ms, "Largest shift searched, ms")
      ->check(cli::Range(10.0, 2000.0))
      ->capture_default_str();
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("time_shift", [&]() -> int {
    const double camera_latency = config::Node::loadFile(config::resolvePreset("camera", camera))
                                      .child("pipeline")
                                      .get<double>("latency");
    const double controller_latency = robot::loadRobotPreset(robot).controller_latency;

    const Samples samples = readLog(log);
    const auto& odometry = samples.odometry;
    const auto& ball = samples.ball;
    const auto vision = fusion::ratesFromBearings(ball);
    std::printf("odometry samples %zu, ball sightings %zu, vision rates %zu\n", odometry.size(),
                ball.size(), vision.size());
    const auto shift =
        fusion::estimateTimeShift(odometry, vision, static_cast<Utime>(max_shift_ms * 1000.0));
    std::printf(
        "configured: camera latency %.1f ms, controller latency %.1f ms (vision %.1f ms "
        "behind odometry)\n",
        camera_latency * 1e3, controller_latency * 1e3,
        (camera_latency - controller_latency) * 1e3);
    if (!shift) {
      std::printf("no estimate: the log needs the robot turning with a ball in view\n");
      return 1;
    }
    std::printf(
        "estimated: vision stamps %+.1f ms off odometry's (correlation %.3f over %d "
        "points) -> vision %.1f ms behind odometry\n",
        static_cast<double>(shift->shift_us) * 1e-3, shift->correlation, shift->samples,
        (camera_latency - controller_latency) * 1e3 + static_cast<double>(shift->shift_us) * 1e-3);
    return 0;
  });
}
