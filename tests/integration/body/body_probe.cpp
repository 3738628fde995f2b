// fieldline-body-probe: the observer of tests/integration/body. Watches robot 1 on the
// simulator's bus (SIM_WORLD truth) and on its own bus (ODOMETRY, the motor bridge's
// SERVICE_STATUS) while the pilot drives it through the motor bridge and the pty, and checks:
//   1. the robot drives 1 m, and odometry (slip off) agrees with the truth;
//   2. ODOMETRY arrives at 50 Hz, controller stamps 20 ms apart;
//   3. after the pilot is killed (SIGKILL to --pilot-pid) the robot is told to stop within the
//      watchdog time: its speed falls and it comes to rest;
//   4. after the serial line is pulled (SIGUSR1 to --sim-pid) ODOMETRY stops and resumes with a
//      resync sample: the bridge reconnected.
// Exit 0 when all hold; prints every measured number.
#include <signal.h>
#include <sys/types.h>

#include <cmath>
#include <deque>
#include <functional>
#include <iostream>

#include <fmt/core.h>

#include "common/bus/node.hpp"
#include "common/bus/urls.hpp"
#include "common/cli/cli.hpp"

using namespace fieldline;

namespace {

struct Truth {
  Utime utime = 0;
  double x = 0, y = 0, speed = 0;
};

int failures = 0;
void check(bool ok, const std::string& what) {
  fmt::print("{} {}\n", ok ? "ok  " : "FAIL", what);
  if (!ok) ++failures;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{"Observer and checker of the body integration test (see the file comment)."};
  int pilot_pid = 0;
  int sim_pid = 0;
  double watchdog = 0.2;
  double latency = 0.008;
  app.add_option("--pilot-pid", pilot_pid, "Process to SIGKILL as the command source")->required();
  app.add_option("--sim-pid", sim_pid, "world_sim process to send SIGUSR1 to")->required();
  app.add_option("--watchdog", watchdog, "Watchdog time [s]")->capture_default_str();
  FIELDLINE_CLI_PARSE(app, argc, argv);

  SystemClock clock;
  bus::Node node(
      {.process = "body_probe", .robot_id = 1, .url = bus::robotBusUrl(1), .status_period_us = 0},
      clock);
  const bus::BusId sim = node.addBus(bus::simBusUrl());
  std::deque<Truth> truth;
  std::vector<odometry_t> odometry;
  node.subscribe(
      bus::channels::kSimWorld,
      [&](const world_state_t& w) {
        for (int i = 0; i < w.num_robots; ++i) {
          if (w.robot_id[i] != 1) continue;
          truth.push_back({w.header.utime, w.robot_x[i], w.robot_y[i],
                           std::hypot(w.robot_vx[i], w.robot_vy[i])});
        }
      },
      sim);
  node.subscribe(bus::channels::kOdometry, [&](const odometry_t& o) { odometry.push_back(o); });

  // Spins until `done` or `limit_s` seconds of waiting (a safety net, not a timing assertion).
  auto spinUntil = [&](const std::function<bool()>& done, double limit_s) {
    const Utime until = clock.now() + static_cast<Utime>(limit_s * 1e6);
    while (!done() && clock.now() < until)
      node.spinOnce(5);
    return done();
  };

  // 1. Driving: wait for the first truth, then for 1 m of travel.
  check(spinUntil([&] { return !truth.empty() && !odometry.empty(); }, 20.0),
        "SIM_WORLD and ODOMETRY are heard");
  if (failures) return 1;
  const Truth start = truth.back();
  const std::size_t odo_start = odometry.size();
  const bool drove = spinUntil(
      [&] { return std::hypot(truth.back().x - start.x, truth.back().y - start.y) >= 1.0; }, 20.0);
  check(drove, "the robot drives 1 m under the pilot's commands");
  // 2. Rate: two more seconds of odometry at cruising speed.
  const std::size_t rate_from = odometry.size();
  spinUntil([] { return false; }, 2.0);
  const auto& first = odometry[rate_from];
  const auto& last = odometry.back();
  const double span = static_cast<double>(last.header.utime - first.header.utime) * 1e-6;
  const double rate = static_cast<double>(odometry.size() - 1 - rate_from) / span;
  const double controller_step =
      static_cast<double>(last.controller_utime - first.controller_utime) /
      static_cast<double>(odometry.size() - 1 - rate_from);
  fmt::print("odometry: {} samples in {:.3f} s = {:.2f} Hz, controller step {:.1f} us\n",
             odometry.size() - rate_from, span, rate, controller_step);
  check(std::abs(rate - 50.0) < 2.0, "ODOMETRY arrives at 50 Hz");
  check(std::abs(controller_step - 20000.0) < 1.0, "controller samples are 20 ms apart");
  double odo_distance = 0.0;
  for (std::size_t i = odo_start + 1; i < odometry.size(); ++i) {
    odo_distance += std::hypot(odometry[i].dx, odometry[i].dy);
  }
  // Truth over the same interval: from the odometry's first to last sampling time.
  auto truthAt = [&](Utime t) {
    for (const auto& s : truth) {
      if (s.utime >= t) return s;
    }
    return truth.back();
  };
  const Truth a = truthAt(odometry[odo_start].header.utime);
  const Truth b = truthAt(odometry.back().header.utime);
  const double true_distance = std::hypot(b.x - a.x, b.y - a.y);
  fmt::print("distance: odometry {:.3f} m, truth {:.3f} m\n", odo_distance, true_distance);
  check(std::abs(odo_distance - true_distance) < 0.05,
        "odometry (no slip) matches the truth within 5 cm");
  const double cruise = truth.back().speed;
  fmt::print("cruising speed {:.3f} m/s\n", cruise);
  check(cruise > 0.5, "the robot is moving before the pilot is killed");

  // 3. Kill the command source.
  const Utime killed = clock.now();
  ::kill(pilot_pid, SIGKILL);
  const std::size_t after_kill = truth.size();
  const bool slowed = spinUntil(
      [&] { return truth.size() > after_kill && truth.back().speed < 0.9 * cruise; }, 5.0);
  const double slow_after = static_cast<double>(truth.back().utime - killed) * 1e-6;
  const bool rested = spinUntil([&] { return truth.back().speed < 0.01; }, 5.0);
  const double rest_after = static_cast<double>(truth.back().utime - killed) * 1e-6;
  fmt::print(
      "after SIGKILL to the pilot: speed below 90 % after {:.3f} s, at rest after {:.3f} s\n",
      slow_after, rest_after);
  // The stop must be commanded within the watchdog time; the motors then need
  // tau * ln(1 / 0.9) = 16 ms to lose 10 % of their speed; plus one SIM_WORLD period.
  check(slowed && slow_after < watchdog + latency + 0.016 + 0.03,
        "the robot stops within the watchdog time after the pilot dies");
  check(rested, "the robot comes to rest");

  // 4. Pull the serial line.
  const std::size_t before_pull = odometry.size();
  ::kill(sim_pid, SIGUSR1);
  const Utime pulled = clock.now();
  spinUntil([] { return false; }, 0.5);
  const std::size_t during = odometry.size();
  const bool resumed = spinUntil(
      [&] {
        for (std::size_t i = during; i < odometry.size(); ++i) {
          if (odometry[i].status & odometry_t::STATUS_RESYNC) return true;
        }
        return false;
      },
      15.0);
  // Samples measured more than 0.1 s after the signal: the simulator handles it at its next step
  // and a few samples may still be in flight, but nothing measured later may come through
  // (counting arrivals instead failed once under load with 3 in-flight samples).
  std::size_t measured_after = 0;
  for (std::size_t i = before_pull; i < during; ++i) {
    measured_after += odometry[i].header.utime > pulled + 100'000 ? 1 : 0;
  }
  fmt::print(
      "serial pulled: {} samples in the first 0.5 s ({} measured > 0.1 s after the pull), "
      "resynced after {:.2f} s\n",
      during - before_pull, measured_after, static_cast<double>(clock.now() - pulled) * 1e-6);
  check(measured_after == 0, "ODOMETRY stops while the serial line is away");
  check(resumed, "the bridge reconnects and ODOMETRY resumes with a resync sample");
  const std::size_t after = odometry.size();
  spinUntil([] { return false; }, 1.0);
  check(odometry.size() - after >= 45, "50 Hz again after reconnecting");
  fmt::print("{}\n", failures ? "FAILED" : "PASSED");
  return failures ? 1 : 0;
}
