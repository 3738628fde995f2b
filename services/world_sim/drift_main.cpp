// fieldline-sim-drift: how far dead reckoning drifts. Runs a scenario in-process (no bus, no
// pty, as fast as it computes), steers every robot along its trajectory from the true pose at
// 50 Hz, integrates one robot's wheel ticks at 50 Hz and prints position and heading error of
// odometry against the truth.
#include <cmath>
#include <iostream>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/robot/trajectory.hpp"
#include "common/robot/wheel_odometry.hpp"
#include "common/scenario/scenario.hpp"
#include "services/world_sim/world.hpp"

using namespace fieldline;

namespace {

struct Options {
  std::string scenario_name = "figure_eight";
  int robot_id = 1;
  double duration = 60.0;
  double report_every = 10.0;
  std::int64_t seed = -1;
  double slip_scale = -1.0;

  void addTo(cli::App& app) {
    app.add_option("--scenario", scenario_name, "Scenario preset name or YAML path")
        ->capture_default_str();
    app.add_option("--robot", robot_id, "Robot whose odometry is measured")
        ->check(cli::Range(1, 6))
        ->capture_default_str();
    app.add_option("--duration", duration, "Simulated seconds")
        ->check(cli::PositiveNumber)
        ->capture_default_str();
    app.add_option("--report-every", report_every, "Print a line every this many seconds")
        ->check(cli::PositiveNumber)
        ->capture_default_str();
    app.add_option("--seed", seed, "Override the scenario's random seed");
    app.add_option("--slip-scale", slip_scale, "Override the scenario's slip scale (0: exact)");
  }
};

// Drives every robot of `world` along its trajectory and prints the odometry error of robot
// `index` every report_every seconds and at the end.
void measureDrift(const Options& options, const scenario::Scenario& scenario,
                  world_sim::World& world, int index) {
  std::vector<robot::Trajectory> paths;
  for (const auto& spec : scenario.robots)
    paths.emplace_back(spec.trajectory, spec.start);
  const auto& params = world.robotParams();
  robot::WheelOdometry odometry(params);
  odometry.reset(world.robots()[index].pose);
  odometry.update(world.ticks(index));
  const double sample_period = 1.0 / params.odometry_rate;
  const auto steps_per_sample = std::max(1L, std::lround(sample_period * scenario.physics_rate));
  const double duration = options.duration;
  double travelled = 0.0;
  double next_report = options.report_every;
  fmt::print("scenario {} seed {} slip_scale {} robot {} (physics {} Hz, odometry {} Hz)\n",
             scenario.name, scenario.seed, scenario.slip_scale, options.robot_id,
             scenario.physics_rate, params.odometry_rate);
  fmt::print("{:>7} {:>9} {:>11} {:>13} {:>11}\n", "t[s]", "path[m]", "pos_err[m]",
             "heading_err[deg]", "err/path[%]");
  while (world.time() < duration - 1e-9) {
    for (std::size_t i = 0; i < paths.size(); ++i) {
      world.setCommand(
          i, robot::followTrajectory(paths[i].at(world.time()), world.robots()[i].pose, params));
    }
    const geometry::Vec2 before = world.robots()[index].pose.position();
    for (long k = 0; k < steps_per_sample; ++k)
      world.step();
    travelled += (world.robots()[index].pose.position() - before).norm();
    odometry.update(world.ticks(index));
    if (world.time() >= next_report - 1e-9 || world.time() >= duration - 1e-9) {
      next_report += options.report_every;
      const auto& truth = world.robots()[index].pose;
      const double position_error = (odometry.pose().position() - truth.position()).norm();
      const double heading_error = geometry::angleDiff(odometry.pose().phi, truth.phi);
      fmt::print("{:7.2f} {:9.2f} {:11.3f} {:13.2f} {:11.2f}\n", world.time(), travelled,
                 position_error, heading_error * 180.0 / std::numbers::pi,
                 travelled > 0.0 ? 100.0 * position_error / travelled : 0.0);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Measures dead-reckoning drift: runs a scenario without bus or pty, drives the robots "
      "along their trajectories from the truth and compares one robot's wheel odometry with "
      "its true pose."};
  Options options;
  options.addTo(app);
  FIELDLINE_CLI_PARSE(app, argc, argv);

  int status = 0;
  config::runOrExit([&] {
    auto scenario = scenario::loadScenarioPreset(options.scenario_name);
    if (options.seed >= 0) scenario.seed = static_cast<std::uint64_t>(options.seed);
    if (options.slip_scale >= 0.0) scenario.slip_scale = options.slip_scale;
    world_sim::World world(scenario);
    const int index = world.indexOf(options.robot_id);
    if (index < 0) {
      std::cerr << "no robot " << options.robot_id << " in scenario " << scenario.name << "\n";
      status = 2;
      return;
    }
    measureDrift(options, scenario, world, index);
  });
  return status;
}
