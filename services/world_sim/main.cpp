// fieldline-world-sim: the simulated world in real time. Physics at the scenario's rate, a
// firmware emulator on a pseudo-terminal per robot (what motor_bridge talks to), SIM_WORLD
// ground truth at 100 Hz on the simulator's bus, stamped with the simulated physical time.
#include <atomic>
#include <csignal>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"
#include "common/process/supervisor_identity.hpp"
#include "common/scenario/scenario.hpp"
#include "services/world_sim/world_sim_node.hpp"

using namespace fieldline;

namespace {
std::atomic<bool> g_pull_serial{false};
extern "C" void onPullSerial(int) {
  g_pull_serial = true;
}
}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "World simulator: robots with the omni drive and motor model, slip, collisions, "
      "opponents, a ball, kidnaps; a firmware emulator per robot on a pseudo-terminal "
      "(<pty-dir>/robot<N>.tty) that speaks the motor controller's serial protocol; SIM_WORLD "
      "ground truth at 100 Hz on the simulator's bus. SIGUSR1 pulls every serial line for "
      "--outage seconds (the bridges must reconnect)."};
  bus::CommonOptions common;
  common.robot = 0;
  common.addTo(app);
  std::string scenario_name = "default";
  world_sim::WorldSimNodeOptions options;
  double outage = 1.0;
  app.add_option("--scenario", scenario_name, "Scenario preset (config/scenarios) or YAML path")
      ->capture_default_str();
  app.add_option("--pty-dir", options.pty_dir, "Folder of the robots' serial links robot<N>.tty")
      ->capture_default_str();
  app.add_option("--outage", outage, "Seconds a serial line stays away after SIGUSR1")
      ->check(cli::Range(0.01, 600.0))
      ->capture_default_str();
  app.add_option("--world-rate", options.world_rate, "SIM_WORLD messages per simulated second")
      ->check(cli::Range(1.0, 1000.0))
      ->capture_default_str();
  app.add_option("--state-file", options.state_file,
                 "Snapshot of the world, written every 0.1 s and when the simulator stops; a "
                 "simulator restarted by the same supervisor (the launcher, systemd) within "
                 "--resume-within continues from it (default: <pty-dir>/world_sim.state)");
  app.add_option("--resume-within", options.resume_within_s,
                 "Resume only from a snapshot at most this many seconds old, s")
      ->check(cli::Range(0.0, 3600.0))
      ->capture_default_str();
  app.add_flag("--fresh", options.fresh,
               "Start the scenario from t = 0 even when a recent snapshot exists");
  // A new run of the launcher (another parent) starts afresh; its restarts resume.
  options.supervisor = process::supervisorIdentity();
  FIELDLINE_PARSE(app, argc, argv);
  if (options.state_file.empty()) options.state_file = options.pty_dir + "/world_sim.state";

  return bus::runMain("world_sim", [&] {
    common.resolve("world_sim");
    const auto scenario = scenario::loadScenarioPreset(scenario_name);
    if (common.print_io) return bus::printIo(world_sim::worldSimIo(scenario, options.pty_dir));
    if (common.check_args) return 0;
    SystemClock clock;
    bus::installStopSignals();
    std::signal(SIGUSR1, onPullSerial);
    bus::Node node({.process = "world_sim", .robot_id = 0, .url = common.sim_bus_url}, clock);
    world_sim::WorldSimNode sim(node, scenario, options);
    node.every(50 * kMicrosPerMilli, [&] {
      if (g_pull_serial.exchange(false)) sim.pullSerialLines(outage);
    });
    return node.run();
  });
}
