// fieldline-pilot: scripted behaviour. Follows its robot's trajectory from the scenario and
// publishes MOTION_COMMAND at 50 Hz, steering with SIM_WORLD ground truth (--steer truth) or
// with its own ROBOT_STATE (--steer state). Without --scenario it holds still: it publishes no
// command, so the motor bridge keeps the robot stopped (a real robot never drives on its own).
#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/cli/cli.hpp"
#include "common/robot/robot_params.hpp"
#include "common/scenario/scenario.hpp"
#include "services/pilot/pilot_node.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Pilot: follows this robot's scripted trajectory from a scenario (figure eight, waypoint "
      "tour, rotation, standing, random play) and publishes MOTION_COMMAND at 50 Hz. Steers "
      "with the simulator's ground truth (SIM_WORLD) or with the robot's own ROBOT_STATE. "
      "Without --scenario it holds still: no MOTION_COMMAND at all, so the motor bridge keeps "
      "the robot stopped and a behaviour module or a joystick may drive it."};
  bus::CommonOptions common;
  common.addTo(app);
  std::string scenario_name;
  std::string robot_config = "fu2004";
  std::string steer = "truth";
  pilot::PilotNodeOptions options;
  app.add_option("--scenario", scenario_name,
                 "Scenario preset (config/scenarios) or YAML path whose trajectory for this robot "
                 "to drive; without it the pilot holds still");
  app.add_option("--robot-config", robot_config, "Robot preset name or YAML path")
      ->capture_default_str();
  app.add_option("--steer", steer, "Pose to steer with: truth (SIM_WORLD) or state (ROBOT_STATE)")
      ->check(cli::IsMember({"truth", "state"}))
      ->capture_default_str();
  app.add_option("--rate", options.rate, "Commands per second")
      ->check(cli::Range(1.0, 500.0))
      ->capture_default_str();
  app.add_option("--command-lifetime", options.command_lifetime,
                 "Seconds each command stays valid (its deadline); the bridge stops the robot "
                 "after that when the pilot goes quiet")
      ->check(cli::Range(0.01, 5.0))
      ->capture_default_str();
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("pilot", [&] {
    common.resolve("pilot");
    const robot::RobotParams params = robot::loadRobotPreset(robot_config);
    const RobotClock clock = bus::robotClockFromEnvironment();
    const auto steer_by = steer == "truth" ? pilot::SteerBy::kTruth : pilot::SteerBy::kState;
    if (common.print_io) {
      return bus::printIo(
          pilot::pilotIo(scenario_name.empty() ? std::nullopt : std::optional(steer_by)));
    }
    if (scenario_name.empty()) {
      if (common.check_args) return 0;
      bus::installStopSignals();
      bus::Node node({.process = "pilot", .robot_id = common.robot, .url = common.bus_url}, clock);
      pilot::holdStill(node);
      return node.run();
    }
    pilot::Pilot pilot(scenario::loadScenarioPreset(scenario_name), common.robot, params);
    if (common.check_args) return 0;
    bus::installStopSignals();
    bus::Node node({.process = "pilot", .robot_id = common.robot, .url = common.bus_url}, clock);
    options.steer = steer_by;
    if (options.steer == pilot::SteerBy::kTruth) options.sim_bus = node.addBus(common.sim_bus_url);
    pilot::PilotNode pilot_node(node, std::move(pilot), options);
    return node.run();
  });
}
