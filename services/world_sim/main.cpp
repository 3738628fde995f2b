// fieldline-world-sim: the simulated world in real time. Physics at the scenario's rate, a
// firmware emulator on a pseudo-terminal per robot (what motor_bridge talks to), SIM_WORLD
// ground truth at 100 Hz on the simulator's bus, stamped with the simulated physical time.
#include <atomic>
#include <csignal>
#include <deque>
#include <memory>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "services/world_sim/firmware.hpp"
#include "services/world_sim/pseudo_terminal.hpp"
#include "services/world_sim/world.hpp"

using namespace fieldline;

namespace {

std::atomic<bool> g_pull_serial{false};
void onPullSerial(int) {
  g_pull_serial = true;
}

struct SimRobot {
  std::unique_ptr<world_sim::FirmwareEmulator> firmware;
  std::unique_ptr<world_sim::PseudoTerminal> pty;
  std::string link_path;
  double next_sample = 0.0;
  // While the serial device is "unplugged": reopen at this simulated time.
  double reopen_at = -1.0;
  std::uint64_t bytes_dropped = 0;
  // Odometry frames on their way: the controller needs controller_latency to send a sample.
  std::deque<std::pair<double, std::vector<std::uint8_t>>> outgoing;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "World simulator: robots with the omni drive and motor model, slip, collisions, "
      "opponents, a ball, kidnaps; a firmware emulator per robot on a pseudo-terminal "
      "(<pty-dir>/robot<N>.tty) that speaks the motor controller's serial protocol; SIM_WORLD "
      "ground truth at 100 Hz on the simulator's bus. SIGUSR1 pulls every serial line for "
      "--outage seconds (the bridges must reconnect)."};
  bus::CommonOptions common;
  common.robot = 0;
  common.addTo(app);
  std::string scenario_name = "default";
  std::string pty_dir = "/tmp/fieldline";
  double outage = 1.0;
  double world_rate = 100.0;
  app.add_option("--scenario", scenario_name, "Scenario preset (config/scenarios) or YAML path")
      ->capture_default_str();
  app.add_option("--pty-dir", pty_dir, "Folder of the robots' serial links robot<N>.tty")
      ->capture_default_str();
  app.add_option("--outage", outage, "Seconds a serial line stays away after SIGUSR1")
      ->check(CLI::Range(0.01, 600.0))
      ->capture_default_str();
  app.add_option("--world-rate", world_rate, "SIM_WORLD messages per simulated second")
      ->check(CLI::Range(1.0, 1000.0))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  return bus::runMain("world_sim", [&] {
    common.resolve("world_sim");
    const auto scenario = world_sim::loadScenarioPreset(scenario_name);
    world_sim::World world(scenario);
    const auto& params = world.robotParams();
    const double sample_period = 1.0 / params.odometry_rate;

    SystemClock clock;
    bus::installStopSignals();
    std::signal(SIGUSR1, onPullSerial);
    bus::Node node({.process = "world_sim", .robot_id = 0, .url = common.sim_bus_url}, clock);

    std::vector<SimRobot> robots(world.robots().size());
    for (std::size_t i = 0; i < robots.size(); ++i) {
      const int id = world.robots()[i].id;
      // Each controller has its own clock, started at a different moment.
      robots[i].firmware = std::make_unique<world_sim::FirmwareEmulator>(
          params, static_cast<std::uint64_t>(id) * 7'000'000ULL);
      robots[i].link_path = pty_dir + "/robot" + std::to_string(id) + ".tty";
      robots[i].pty = std::make_unique<world_sim::PseudoTerminal>(robots[i].link_path);
      robots[i].next_sample = sample_period;
      spdlog::info("robot {}: serial line {} -> {}", id, robots[i].link_path,
                   robots[i].pty->slavePath());
    }
    std::size_t next_outage = 0;
    auto outages = scenario.serial_outages;
    std::sort(outages.begin(), outages.end(),
              [](const auto& a, const auto& b) { return a.time < b.time; });
    auto pull = [&](std::size_t i, double t, double duration) {
      if (!robots[i].pty) return;
      spdlog::info("robot {}: serial line pulled for {} s", world.robots()[i].id, duration);
      robots[i].pty.reset();
      robots[i].reopen_at = t + duration;
    };

    const Utime start = clock.now();
    auto simUtime = [&](double t) { return start + static_cast<Utime>(std::llround(t * 1e6)); };
    double next_world = 0.0;
    std::vector<std::uint8_t> in;
    std::vector<std::uint8_t> out;
    world_state_t msg{};
    msg.field = world.field().name();
    msg.scenario = scenario.name;
    msg.robot_radius = static_cast<float>(params.radius);

    auto publishWorld = [&](double t) {
      const auto& rs = world.robots();
      msg.header.utime = simUtime(t);
      msg.num_robots = static_cast<std::int32_t>(rs.size());
      msg.robot_id.resize(rs.size());
      msg.robot_x.resize(rs.size());
      msg.robot_y.resize(rs.size());
      msg.robot_phi.resize(rs.size());
      msg.robot_vx.resize(rs.size());
      msg.robot_vy.resize(rs.size());
      msg.robot_omega.resize(rs.size());
      msg.robot_kidnaps.resize(rs.size());
      for (std::size_t i = 0; i < rs.size(); ++i) {
        msg.robot_id[i] = static_cast<std::int8_t>(rs[i].id);
        msg.robot_x[i] = rs[i].pose.x;
        msg.robot_y[i] = rs[i].pose.y;
        msg.robot_phi[i] = rs[i].pose.phi;
        msg.robot_vx[i] = rs[i].velocity.x();
        msg.robot_vy[i] = rs[i].velocity.y();
        msg.robot_omega[i] = rs[i].omega;
        msg.robot_kidnaps[i] = rs[i].kidnaps;
      }
      const auto& os = world.opponents();
      msg.num_opponents = static_cast<std::int32_t>(os.size());
      msg.opponent_x.resize(os.size());
      msg.opponent_y.resize(os.size());
      msg.opponent_phi.resize(os.size());
      msg.opponent_radius.resize(os.size());
      for (std::size_t k = 0; k < os.size(); ++k) {
        msg.opponent_x[k] = os[k].pose.x;
        msg.opponent_y[k] = os[k].pose.y;
        msg.opponent_phi[k] = os[k].pose.phi;
        msg.opponent_radius[k] = static_cast<float>(os[k].radius);
      }
      msg.ball_x = world.ball().position.x();
      msg.ball_y = world.ball().position.y();
      msg.ball_vx = world.ball().velocity.x();
      msg.ball_vy = world.ball().velocity.y();
      msg.ball_radius = static_cast<float>(world.ball().radius);
      node.publish(bus::channels::kSimWorld, msg);
    };

    node.every(kMicrosPerSecond, [&] {
      node.setMetric("sim_time_s", world.time());
      node.setMetric("realtime_factor",
                     world.time() / std::max(1e-6, (clock.now() - start) * 1e-6));
      for (std::size_t i = 0; i < robots.size(); ++i) {
        const std::string r = "r" + std::to_string(world.robots()[i].id) + "_";
        node.setMetric(r + "speed_mps", world.robots()[i].velocity.norm());
        node.setMetric(r + "commands_total",
                       static_cast<double>(robots[i].firmware->stats().commands_accepted));
        node.setMetric(r + "watchdog_stops",
                       static_cast<double>(robots[i].firmware->stats().watchdog_stops));
        node.setMetric(r + "serial_bad_frames",
                       static_cast<double>(robots[i].firmware->decoderStats().badFrames()));
        node.setMetric(r + "serial_bytes_dropped", static_cast<double>(robots[i].bytes_dropped));
      }
    });

    while (!node.stopRequested()) {
      node.spinOnce(1);
      // Real time only: every process stamps with the system clock, and SIM_WORLD's stamps must
      // agree with theirs (faster-than-real-time runs go through fieldline-sim-drift, offline).
      const double target = (clock.now() - start) * 1e-6;
      if (scenario.duration > 0.0 && world.time() >= scenario.duration) break;
      if (g_pull_serial.exchange(false)) {
        for (std::size_t i = 0; i < robots.size(); ++i)
          pull(i, world.time(), outage);
      }
      // Step only up to the present: a state is never stamped later than it is published.
      while (world.time() + world.stepSeconds() <= target) {
        const double t = world.time();
        while (next_outage < outages.size() && outages[next_outage].time <= t) {
          const int index = world.indexOf(outages[next_outage].robot);
          if (index >= 0) pull(static_cast<std::size_t>(index), t, outages[next_outage].duration);
          ++next_outage;
        }
        for (std::size_t i = 0; i < robots.size(); ++i) {
          auto& r = robots[i];
          if (!r.pty && r.reopen_at >= 0.0 && t >= r.reopen_at) {
            try {
              r.pty = std::make_unique<world_sim::PseudoTerminal>(r.link_path);
              r.firmware->lineReset();
              r.reopen_at = -1.0;
              spdlog::info("robot {}: serial line back at {}", world.robots()[i].id,
                           r.pty->slavePath());
            } catch (const std::exception& e) {
              // The simulation goes on without this robot's line; try again in a second.
              node.reportError("pty", e.what());
              r.reopen_at = t + 1.0;
            }
          }
          if (r.pty) {
            in.clear();
            out.clear();
            if (r.pty->read(in) > 0) r.firmware->receive(in, t, out);
            if (!out.empty()) r.bytes_dropped += r.pty->write(out);
            while (!r.outgoing.empty() && r.outgoing.front().first <= t) {
              r.bytes_dropped += r.pty->write(r.outgoing.front().second);
              r.outgoing.pop_front();
            }
          } else {
            r.outgoing.clear();
          }
          world.setCommand(i, r.firmware->motorCommand(t));
        }
        world.step();
        const double now_sim = world.time();
        for (std::size_t i = 0; i < robots.size(); ++i) {
          auto& r = robots[i];
          if (now_sim + 1e-9 < r.next_sample) continue;
          r.next_sample += sample_period;
          std::vector<std::uint8_t> frame;
          r.firmware->sample(now_sim, world.ticks(i), frame);
          r.outgoing.emplace_back(now_sim + params.controller_latency, std::move(frame));
        }
        if (now_sim + 1e-9 >= next_world) {
          next_world += 1.0 / world_rate;
          // When the simulation fell behind (a starved CPU at start-up), states from the catch-up
          // would be stale on arrival: publish only the ones within a period of the present.
          if (target - now_sim < 1.0 / world_rate) publishWorld(now_sim);
        }
      }
    }
    return 0;
  });
}
