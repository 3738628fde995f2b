// fieldline-replay: a recorded robot-bus log through the named algorithm nodes in one process,
// deterministically (log-time order, simulated clock, fixed publisher ids): two replays of the
// same log write byte-identical outputs. See docs/replay.md.
#include <cstdio>
#include <optional>
#include <string>

#include "common/bus/cli.hpp"
#include "common/bus/log_file.hpp"
#include "common/cli/cli.hpp"
#include "tools/recording/upgrade.hpp"
#include "tools/replay/replay_run.hpp"

using namespace fieldline;

namespace {

void addOptions(cli::App& app, replay::ReplayRunOptions& options, std::string& run) {
  app.add_option("log", options.log_path,
                 "The recorded log of one robot's bus, or a recording's directory with --robot "
                 "(its robotN.lcm and robotN_partNNN.lcm in order; its sim.lcm as --truth)")
      ->required()
      ->check(cli::ExistingPath);
  app.add_option("--run", run,
                 "Nodes to run, comma-separated: region_tracking, feature_recognition, fusion")
      ->capture_default_str();
  app.add_option("--out,-o", options.out_path,
                 "LCM log to write the run nodes' outputs to (overwritten; default: none)");
  app.add_option("--robot", options.robot_id,
                 "Robot id of the log (default: taken from its first ODOMETRY / VISION_LINES / "
                 "CAMERA_IMAGE)")
      ->check(cli::Range(1, 6));
  app.add_option("--field", options.field,
                 "Field preset (msl, fu2004) or YAML path (default: the recording's field, else "
                 "msl)");
  app.add_option("--robot-config", options.robot_config, "fusion: robot preset or YAML path")
      ->capture_default_str();
  app.add_option("--fusion-config", options.fusion_config,
                 "fusion: settings preset (config/fusion/NAME.yaml) or YAML path, as "
                 "fieldline-fusion --config (default: the settings the recording says fusion "
                 "ran with, else default)");
  app.add_option("--matcher", options.matcher,
                 "fusion: layer 2 method, lsq or force_field (default: the settings file's)")
      ->check(cli::IsMember({"lsq", "force_field"}));
  app.add_option("--start-prior", options.start_prior, "fusion: own_half or none")
      ->check(cli::IsMember({"own_half", "none"}))
      ->capture_default_str();
  app.add_option("--grid-cache", options.grid_cache,
                 "fusion: distance grid cache directory (default: none, built in memory)");
  app.add_option("--truth", options.truth_path,
                 "The simulator's log of the same run (sim.lcm): its SIM_WORLD is merged into "
                 "--out and --live-out, so fieldline-eval --log can score them")
      ->check(cli::ExistingFile);
  app.add_option("--live-out", options.live_out_path,
                 "Also write what the live processes published on the run nodes' output channels "
                 "(with --truth's SIM_WORLD) to this log, to compare with the replay");
  app.add_flag("--oracle-contact", options.oracle_contact,
               "Analysis only: replace the log's VISION_OBSTACLES by the truth's contact state "
               "(--truth: this robot's centre closer to another robot's or an opponent's than "
               "the two radii) fed as contact evidence, to measure what a perfect contact signal "
               "could give");
  app.add_option("--stall", options.stall_s,
                 "Analysis: inject stalls of this many seconds (a starved process); what happens "
                 "to each channel's inputs within a stall: --stall-hold, --stall-drop "
                 "(default 0: no stalls)")
      ->check(cli::Range(0.0, 60.0));
  app.add_option("--stall-every", options.stall_every_s, "Seconds from one stall to the next")
      ->capture_default_str();
  app.add_option("--stall-start", options.stall_start_s,
                 "Seconds after the log's first input of the first stall")
      ->capture_default_str();
  app.add_option("--stall-hold", options.stall_hold,
                 "Channels whose inputs within a stall are delivered together at its end (a "
                 "starved receiver or motor bridge), e.g. ODOMETRY")
      ->delimiter(',');
  app.add_option("--stall-drop", options.stall_drop,
                 "Channels whose inputs within a stall are dropped (a starved camera), e.g. "
                 "VISION_LINES,FIELD_FEATURES")
      ->delimiter(',');
  app.add_option("--camera", options.camera, "region_tracking: camera preset")
      ->capture_default_str();
  app.add_option("--max-refused", options.max_refused_share,
                 "Fail (exit code 1) when more than this share of the inputs is refused")
      ->check(cli::Range(0.0, 1.0))
      ->capture_default_str();
}

// The robot's clock from the command line, if given.
struct ClockArgs {
  std::optional<double> offset_s;
  double drift_ppm = 0.0;
  bool none = false;
  void addTo(cli::App& app) {
    app.add_option("--clock-offset", offset_s,
                   "The robot's clock minus the log's time, s (default: the recording's own "
                   "clock model, else fitted to the log's traffic)")
        ->check(cli::Range(-3600.0, 3600.0));
    app.add_option("--clock-drift", drift_ppm, "With --clock-offset: the clock's drift, ppm")
        ->check(cli::Range(-kMaxClockDriftPpm, kMaxClockDriftPpm));
    app.add_flag("--clock-none", none,
                 "Take the robot's stamps as the log's clock (a robot that recorded its own bus)");
  }
};

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Replays a recorded robot-bus LCM log (lcm-logger's format, e.g. scripts/demo --record) "
      "through the named algorithm nodes in one process, in log-time order under a simulated "
      "clock, and writes what they publish to an LCM log. The nodes run on the robot's own clock "
      "(the recording's clock model, else one fitted to the log's traffic; --clock-offset to "
      "give it). The log's own messages on channels the run nodes produce are not fed (the "
      "replayed outputs replace them). Two replays of a log give byte-identical outputs. Prints "
      "a summary line (messages in and out per channel, the clock), what was refused and why; "
      "exit code 1 when more than --max-refused of the inputs were refused or no valid estimate "
      "came out (fusion: no ROBOT_STATE tracking), 2 for bad arguments.\n"
      "Example: fieldline-replay robot1.lcm --run feature_recognition,fusion --out replayed.lcm"};
  replay::ReplayRunOptions options;
  std::string run = "feature_recognition,fusion";
  addOptions(app, options, run);
  ClockArgs clock;
  clock.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);
  if (clock.none && clock.offset_s) {
    std::fprintf(stderr, "fieldline-replay: --clock-none and --clock-offset exclude each other\n");
    return 2;
  }
  if (clock.none) options.clock = ClockError{};
  if (clock.offset_s) {
    // The drift counts from the log's first event: what a user can say about a clock.
    options.clock = ClockError{static_cast<Utime>(*clock.offset_s * 1e6), clock.drift_ppm, 0};
  }

  try {
    options.run = replay::parseRunList(run);
  } catch (const replay::ReplayArgumentError& e) {
    std::fprintf(stderr, "fieldline-replay: --run: %s\n", e.what());
    return 2;
  }

  // Recordings made with older message types are read as today's (docs/replay.md).
  recording::installLogUpgrades();
  return bus::runMain("replay", [&]() -> int {
    try {
      const replay::ReplayRunResult result = replay::runReplay(options);
      std::printf("%s\n", replay::summaryLine(result).c_str());
      if (const std::string refusals = replay::refusalReport(result); !refusals.empty())
        std::printf("%s\n", refusals.c_str());
      const std::vector<std::string> failures = replay::failures(result, options);
      for (const std::string& why : failures)
        std::fprintf(stderr, "fieldline-replay: FAILED: %s\n", why.c_str());
      return failures.empty() ? 0 : 1;
    } catch (const replay::ReplayArgumentError& e) {
      std::fprintf(stderr, "fieldline-replay: %s\n", e.what());
      return 2;
    }
  });
}
