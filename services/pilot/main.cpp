// fieldline-pilot: scripted behaviour. Follows its robot's trajectory from the scenario and
// publishes MOTION_COMMAND at 50 Hz, steering with SIM_WORLD ground truth (--steer truth) or
// with its own ROBOT_STATE (--steer state).
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/robot/robot_params.hpp"
#include "services/pilot/pilot.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  CLI::App app{
      "Pilot: follows this robot's scripted trajectory from a scenario (figure eight, waypoint "
      "tour, rotation, standing, random play) and publishes MOTION_COMMAND at 50 Hz. Steers "
      "with the simulator's ground truth (SIM_WORLD) or with the robot's own ROBOT_STATE."};
  bus::CommonOptions common;
  common.addTo(app);
  std::string scenario_name = "default";
  std::string robot_config = "fu2004";
  std::string steer = "truth";
  double rate = 50.0;
  double command_lifetime = 0.1;
  app.add_option("--scenario", scenario_name, "Scenario preset (config/scenarios) or YAML path")
      ->capture_default_str();
  app.add_option("--robot-config", robot_config, "Robot preset name or YAML path")
      ->capture_default_str();
  app.add_option("--steer", steer, "Pose to steer with: truth (SIM_WORLD) or state (ROBOT_STATE)")
      ->check(CLI::IsMember({"truth", "state"}))
      ->capture_default_str();
  app.add_option("--rate", rate, "Commands per second")
      ->check(CLI::Range(1.0, 500.0))
      ->capture_default_str();
  app.add_option("--command-lifetime", command_lifetime,
                 "Seconds each command stays valid (its deadline); the bridge stops the robot "
                 "after that when the pilot goes quiet")
      ->check(CLI::Range(0.01, 5.0))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  return bus::runMain("pilot", [&] {
    common.resolve("pilot");
    const auto scenario = world_sim::loadScenarioPreset(scenario_name);
    const auto params = robot::loadRobotPreset(robot_config);
    pilot::Pilot pilot(scenario, common.robot, params);

    SystemClock clock;
    bus::installStopSignals();
    bus::Node node({.process = "pilot", .robot_id = common.robot, .url = common.bus_url}, clock);
    if (steer == "truth") {
      const bus::BusId sim = node.addBus(common.sim_bus_url);
      node.subscribe(
          bus::channels::kSimWorld,
          [&](const world_state_t& w) {
            for (int i = 0; i < w.num_robots; ++i) {
              if (w.robot_id[i] != common.robot) continue;
              pilot.onPose({w.robot_x[i], w.robot_y[i], w.robot_phi[i]}, w.header.utime);
            }
          },
          sim);
    } else {
      node.subscribe(bus::channels::kRobotState, [&](const robot_state_t& s) {
        if (s.status == robot_state_t::STATUS_UNKNOWN) return;
        pilot.onPose({s.x, s.y, s.phi}, s.header.utime);
      });
    }

    std::int64_t waiting = 0;
    node.every(static_cast<Utime>(1e6 / rate), [&] {
      const Utime now = node.now();
      const auto cmd = pilot.command(now);
      if (!cmd) {
        // No fresh pose: say nothing, so the bridge lets the robot stop.
        if (waiting++ % static_cast<std::int64_t>(rate * 5) == 0) {
          spdlog::info("waiting for a pose ({})", steer == "truth" ? "SIM_WORLD" : "ROBOT_STATE");
        }
        return;
      }
      motion_command_t m{};
      m.header.utime = now;
      m.vx = cmd->vx;
      m.vy = cmd->vy;
      m.omega = cmd->omega;
      m.deadline_utime = now + static_cast<Utime>(command_lifetime * 1e6);
      m.source = motion_command_t::SOURCE_PILOT;
      node.publish(bus::channels::kMotionCommand, m);
    });
    node.every(kMicrosPerSecond, [&] {
      if (const auto ref = pilot.reference(node.now())) {
        node.setMetric("reference_speed_mps", ref->velocity.norm());
      }
    });
    return node.run();
  });
}
