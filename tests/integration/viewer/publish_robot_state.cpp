// Test helper for viewer_test.sh: publishes a fixed ROBOT_STATE for one robot on its bus at
// 20 Hz until stopped, and prints the published values once as a JSON line, so the test can
// compare them with what the viewer serves.
#include <cstdio>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{"Publishes a fixed ROBOT_STATE on robot N's bus at 20 Hz (viewer test helper)."};
  int robot = 3;
  double duration_s = 10.0;
  app.add_option("--robot", robot, "Robot 1..6")->check(cli::Range(1, 6));
  app.add_option("--duration", duration_s, "Seconds to publish")->check(cli::Range(0.1, 60.0));
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  return bus::runMain("publish_robot_state", [&] {
    SystemClock clock;
    bus::installStopSignals();
    bus::Node node({.process = "publish_robot_state", .robot_id = robot, .status_period_us = 0},
                   clock);
    // Values that are not round in decimal, so a lossy number format would show.
    robot_state_t m{};
    m.x = 1.0 / 3.0;
    m.y = -2.718281828459045;
    m.phi = 0.7853981633974483;
    m.vx = 0.1;
    m.vy = -0.2;
    m.omega = 0.3;
    const double covariance[9] = {0.01,    0.002,  0.0001,  0.002, 0.02,
                                  -0.0003, 0.0001, -0.0003, 0.005};
    for (int i = 0; i < 9; ++i)
      m.covariance[i] = covariance[i];
    m.status = robot_state_t::STATUS_TRACKING;
    m.since_vision_us = 40'000;
    std::printf(
        "{\"x\":%.17g,\"y\":%.17g,\"phi\":%.17g,\"vx\":%.17g,\"vy\":%.17g,\"omega\":%.17g,"
        "\"covariance\":[",
        m.x, m.y, m.phi, m.vx, m.vy, m.omega);
    for (int i = 0; i < 9; ++i)
      std::printf("%s%.17g", i > 0 ? "," : "", m.covariance[i]);
    std::printf("],\"status\":%d,\"since_vision_us\":%lld}\n", m.status,
                static_cast<long long>(m.since_vision_us));
    std::fflush(stdout);
    node.every(50 * kMicrosPerMilli, [&] {
      m.header.utime = node.now();
      node.publish(bus::channels::kRobotState, m);
    });
    node.at(node.now() + static_cast<Utime>(duration_s * 1e6), [&] { node.requestStop(); });
    return node.run();
  });
}
