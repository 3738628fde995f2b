// A tiny bus node for the launcher's integration test: publishes MOTION_COMMAND (zero velocity)
// at 10 Hz and SERVICE_STATUS at 1 Hz on its robot's bus, and says hello on stdout.
#include <csignal>
#include <cstdio>
#include <string>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"

int main(int argc, char** argv) {
  using namespace fieldline;
  bus::CommonOptions common;
  std::string tag;
  bool ignore_sigterm = false;
  cli::App app{"Test node for fieldline-launch: publishes MOTION_COMMAND at 10 Hz"};
  common.addTo(app);
  app.add_option("--tag", tag, "Any text, so a test can find its own processes");
  app.add_flag("--ignore-sigterm", ignore_sigterm,
               "Ignore SIGTERM (tests the launcher's SIGKILL after the grace period)");
  FIELDLINE_PARSE(app, argc, argv);
  return bus::runMain("launch_test_node", [&] {
    common.resolve("launch_test_node");
    if (common.check_args) return 0;
    SystemClock clock;
    bus::Node node({.process = "test_node", .robot_id = common.robot, .url = common.bus_url},
                   clock);
    motion_command_t command{};
    command.source = motion_command_t::SOURCE_PILOT;
    node.every(100 * kMicrosPerMilli, [&] {
      command.header.utime = node.now();
      command.deadline_utime = command.header.utime + 200 * kMicrosPerMilli;
      node.publish(bus::channels::kMotionCommand, command);
    });
    bus::installStopSignals();
    if (ignore_sigterm) std::signal(SIGTERM, SIG_IGN);
    std::printf("test node up: robot %d tag %s\n", common.robot, tag.c_str());
    std::fflush(stdout);
    while (!node.stopRequested())
      node.spinOnce(100);
    std::printf("test node robot %d stopping\n", common.robot);
    return 0;
  });
}
