// fieldline-eval-ball: the ball detector on rendered frames with orange clutter off the field
// and people in red at the side (issue 12), given the field and the robot's pose as fusion would
// (issue 30). Prints one summary line; exits 1 on a false ball, a ball reported outside the
// field, or when the found rate is below --min-found-rate. The logic is in ball_evaluation.*.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "common/cli/cli.hpp"
#include "tools/colour_calibrate/evaluation.hpp"
#include "tools/eval_ball/ball_evaluation.hpp"
#include "tools/eval_real/eval_real.hpp"

int main(int argc, char** argv) {
  using namespace fieldline;
  cli::App app{"Ball detector against the truth on rendered frames with clutter"};
  eval_ball::BallEvalOptions options;
  std::string camera = "omni_sim", field = "msl", realism = "clean";
  double minFoundRate = 0.0;
  app.add_option("--frames", options.frames, "Frames to render and track")
      ->check(cli::PositiveNumber);
  app.add_option("--seed", options.seed, "Seed of the scenes");
  app.add_option("--camera", camera, "Camera preset (config/camera/<name>.yaml)");
  app.add_option("--field", field, "Field preset (config/field/<name>.yaml)");
  app.add_option("--realism", realism, "Realism setting (clean, noise, washed, blur, all, ...)");
  app.add_option("--orange-objects", options.orange_objects, "Orange objects off the field")
      ->check(cli::NonNegativeNumber);
  app.add_option("--people", options.people, "People in red at the side")
      ->check(cli::NonNegativeNumber);
  app.add_option("--min-found-rate", minFoundRate, "Exit 1 when the found rate is lower")
      ->check(cli::Range(0.0, 1.0));
  app.add_option("--pose-sigma", options.pose_sigma_m,
                 "Error of the pose the detector is given (as fusion's), m")
      ->check(cli::Range(0.0, 2.0));
  bool noField = false;
  app.add_flag("--no-field", noField, "no field check: the detector judges by the image alone");
  bool noChecks = false;
  app.add_flag("--no-checks", noChecks,
               "no size, fill or carpet check (the comparison: what they buy)");
  std::vector<std::string> venues;
  app.add_option("--venue", venues,
                 "A rendered venue case (tests/data/venue_cases/NAME.yaml; repeatable) instead: "
                 "the mirror and colours calibrated from its frames as at a venue, then the "
                 "detector on every frame (fieldline-eval-real's venue run; exit 1 when the ball "
                 "is found in fewer than its min_ball_found of the frames it is in view or "
                 "reported outside the field)");
  FIELDLINE_CLI_PARSE(app, argc, argv);
  if (!venues.empty()) {
    try {
      bool failed = false;
      for (const std::string& venue : venues) {
        const evalreal::CaseResult r = evalreal::runCase(venue);
        std::printf("%s: %s\n", r.name.c_str(), r.figures.c_str());
        for (const std::string& f : r.failed)
          std::printf("  FAIL %s\n", f.c_str());
        failed = failed || !r.failed.empty() || r.kind != "venue";
      }
      return failed ? 1 : 0;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fieldline-eval-ball: %s\n", e.what());
      return 2;
    }
  }
  options.field_check = !noField;
  try {
    options.realism = calibration::realismSetting(realism).realism;
    region_tracking::SimCamera sim = region_tracking::SimCamera::load(camera, field);
    region_tracking::VisionParams vision = region_tracking::defaultVisionParams();
    if (noChecks)
      vision.ball = {
          .size_tolerance = 1e3, .size_slack_px = 1e3, .min_fill = 0, .min_carpet_share = 0};
    const eval_ball::BallEvalResult result = eval_ball::evaluateBall(sim, vision, options);
    for (const auto& f : result.first_false) {
      std::printf("false ball: frame %d at (%.2f, %.2f) m, true ball at %.2f m\n", f.frame, f.x,
                  f.y, f.truth_distance);
    }
    std::printf("%s\n%s\n", eval_ball::missLine(result).c_str(),
                eval_ball::summaryLine(result).c_str());
    return result.false_balls > 0 || result.outside_field > 0 || result.foundRate() < minFoundRate
               ? 1
               : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fieldline-eval-ball: %s\n", e.what());
    return 2;
  }
}
