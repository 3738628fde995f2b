// fieldline-rehearsal-probe: how well a robot started by the real launch file localizes against
// the simulator's truth (tests/integration/rehearsal). Listens to SIM_WORLD on the simulator's bus
// and to ROBOT_STATE and VISION_LINES on the robot's bus; from the robot's first TRACKING it
// collects --window seconds of ROBOT_STATE, scores them with fieldline-eval's matching
// (tools/eval/evaluation.hpp: truth interpolated at each state's time) and prints
//
//   TRACKING 1.23 s after the robot's first VISION_LINES (4.56 s after this probe started)
//   mean position error 1.9 cm over 30.0 s (1500 states; p99 4.1 cm, max 5.2 cm; heading 0.4 deg)
//
// Exit code 0 when TRACKING came within --tracking-within s of the first VISION_LINES and the
// mean error is at most --max-mean-cm; 1 otherwise (and when no TRACKING came within --timeout).
// The robot's clock is the true time (a single real robot: no clock offset).
#include <cstdio>
#include <map>
#include <optional>
#include <vector>

#include <fieldline/line_contours_t.hpp>
#include <fieldline/robot_state_t.hpp>
#include <fieldline/world_state_t.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"
#include "common/time/clock.hpp"
#include "tools/eval/evaluation.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{"Scores a robot's ROBOT_STATE against SIM_WORLD from its first TRACKING on"};
  bus::CommonOptions common;
  common.addTo(app);
  double window_s = 30.0;
  double tracking_within_s = 5.0;
  double max_mean_cm = 5.0;
  double timeout_s = 120.0;
  app.add_option("--window", window_s, "Seconds of ROBOT_STATE scored from the first TRACKING")
      ->capture_default_str();
  app.add_option("--tracking-within", tracking_within_s,
                 "TRACKING at most this long after the first VISION_LINES, s")
      ->capture_default_str();
  app.add_option("--max-mean-cm", max_mean_cm, "Mean position error at most this, cm")
      ->capture_default_str();
  app.add_option("--timeout", timeout_s, "Give up without TRACKING after this long, s")
      ->capture_default_str();
  FIELDLINE_PARSE(app, argc, argv);
  common.resolve("rehearsal_probe");

  return bus::runMain("rehearsal_probe", [&] {
    SystemClock clock;
    bus::installStopSignals();
    bus::Node node({.process = "rehearsal_probe",
                    .robot_id = common.robot,
                    .url = common.bus_url,
                    .status_period_us = 0},
                   clock);
    const bus::BusId sim = node.addBus(common.sim_bus_url);
    const Utime started = clock.now();
    std::vector<eval::TruthSample> truth;
    std::vector<eval::StateSample> states;
    std::optional<Utime> first_lines;
    std::optional<Utime> first_tracking;
    node.subscribe(
        bus::channels::kSimWorld,
        [&](const world_state_t& w) {
          eval::TruthSample t;
          t.utime = w.header.utime;
          for (int i = 0; i < w.num_robots; ++i) {
            const auto k = static_cast<std::size_t>(i);
            t.robots[w.robot_id[k]] = {w.robot_x[k], w.robot_y[k], w.robot_phi[k],
                                       w.robot_kidnaps[k]};
          }
          if (truth.empty() || t.utime > truth.back().utime) truth.push_back(std::move(t));
        },
        sim);
    node.subscribe(bus::channels::kVisionLines, [&](const line_contours_t& m) {
      if (m.header.robot_id == common.robot && !first_lines) first_lines = m.header.utime;
    });
    node.subscribe(bus::channels::kRobotState, [&](const robot_state_t& m) {
      if (m.header.robot_id != common.robot) return;
      eval::StateSample s;
      s.robot = m.header.robot_id;
      s.utime = m.header.utime;
      s.published = m.header.utime_published;
      s.x = m.x;
      s.y = m.y;
      s.phi = m.phi;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          s.covariance(r, c) = m.covariance[3 * r + c];
      s.status = m.status;
      if (!first_tracking && s.status == robot_state_t::STATUS_TRACKING) first_tracking = s.utime;
      if (first_tracking) states.push_back(s);
    });
    const auto window_us = static_cast<Utime>(window_s * 1e6);
    Utime last_progress = started;
    while (!bus::stopSignalReceived()) {
      node.spinOnce(50);
      const Utime now = clock.now();
      if (!first_tracking && now - started > static_cast<Utime>(timeout_s * 1e6)) break;
      if (first_tracking && !states.empty() && states.back().utime - *first_tracking >= window_us)
        break;
      if (now - last_progress >= 5 * kMicrosPerSecond) {
        last_progress = now;
        std::fprintf(stderr, "probe: %.0f s, %s, %zu states scored so far\n",
                     (now - started) * 1e-6,
                     first_tracking ? "TRACKING"
                     : first_lines  ? "seeing, not tracking yet"
                                    : "no VISION_LINES yet",
                     states.size());
      }
    }
    if (!first_tracking) {
      std::printf("no TRACKING within %.0f s (%s)\n", timeout_s,
                  first_lines ? "VISION_LINES came" : "no VISION_LINES came either");
      return 1;
    }
    eval::EvalOptions options;
    options.settle_s = 0.0;  // scored from the first TRACKING on
    const eval::Summary s =
        eval::evaluate(truth, states, {}, options, {{common.robot, first_lines.value_or(0)}});
    const double after_lines =
        first_lines ? static_cast<double>(*first_tracking - *first_lines) * 1e-6 : -1.0;
    const double scored_s =
        states.empty() ? 0.0
                       : static_cast<double>(states.back().utime - states.front().utime) * 1e-6;
    std::printf(
        "TRACKING %.2f s after the robot's first VISION_LINES (%.2f s after this probe "
        "started)\n",
        after_lines, static_cast<double>(*first_tracking - started) * 1e-6);
    std::printf(
        "mean position error %.2f cm over %.1f s (%zu states; p99 %.2f cm, max %.2f cm; "
        "heading %.2f deg)\n",
        100 * s.pos_mean_m, scored_s, s.scored, 100 * s.pos_p99_m, 100 * s.pos_max_m,
        s.heading_mean_deg);
    bool ok = true;
    if (!first_lines || after_lines > tracking_within_s) {
      std::printf("FAIL: TRACKING later than %.1f s after the first VISION_LINES\n",
                  tracking_within_s);
      ok = false;
    }
    if (s.scored == 0 || scored_s < 0.9 * window_s || 100 * s.pos_mean_m > max_mean_cm) {
      std::printf("FAIL: mean position error above %.1f cm or fewer than %.0f s scored\n",
                  max_mean_cm, 0.9 * window_s);
      ok = false;
    }
    return ok ? 0 : 1;
  });
}
