// fieldline-eval-localize: layer 2's covariance against the truth on frames rendered through a
// camera that is not what the software believes (the distance function a few percent off, the
// mirror centre and axis off, a tilted camera): NEES in band, errors, sigmas. Exits 1 when the
// share of valid answers with the NEES in the chi-square(3) 95 % band is below --min-in-band.
// The logic is in localize_evaluation.*.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "tools/localize/localize_evaluation.hpp"

namespace {

using namespace fieldline;

// The true cameras and poses drawn, and the guesses.
void addEvaluationOptions(cli::App& app, localize_eval::LocalizeEvalOptions& options) {
  app.add_option("--cameras", options.cameras, "True cameras drawn at random")
      ->check(cli::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--poses", options.poses, "Poses per camera")
      ->check(cli::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Seed of the cameras and poses")->capture_default_str();
  app.add_option("--max-scale", options.max_scale, "Largest relative distance error")
      ->check(cli::Range(0.0, 0.3))
      ->capture_default_str();
  app.add_option("--max-centre-px", options.max_centre_px, "Largest mirror centre error, px")
      ->check(cli::Range(0.0, 30.0))
      ->capture_default_str();
  app.add_option("--max-axis-offset", options.max_axis_offset_m,
                 "Largest mirror axis offset from the robot's centre, m")
      ->check(cli::Range(0.0, 0.3))
      ->capture_default_str();
  app.add_option("--max-tilt", options.max_tilt,
                 "Largest tilt: relative distance error toward one side")
      ->check(cli::Range(0.0, 0.3))
      ->capture_default_str();
  app.add_option("--guess-m", options.guess_m, "Guess this far from the truth, m")
      ->check(cli::Range(0.0, 2.0))
      ->capture_default_str();
  app.add_option("--guess-rad", options.guess_rad, "Guess turned by this, rad")
      ->check(cli::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_flag("--global", options.global, "No guess: the global search");
}

// One line per frame: the truth, the answer, its error, NEES and sigmas.
void printFrames(const std::vector<localize_eval::FrameResult>& frames) {
  for (const auto& f : frames) {
    const auto& c = f.correction;
    std::printf(
        "camera %d truth (%.2f, %.2f, %.2f) valid %d err %.4f m %.2f deg (%.4f %.4f %.5f) "
        "nees %.2f sigma (%.4f, %.4f, %.4f) points %d cells %.0f rms %.4f infl %.2f shape "
        "%.2f runner %d delta %.2f\n",
        f.camera, f.truth.x, f.truth.y, f.truth.phi, c.valid ? 1 : 0, f.position_error,
        f.heading_error * 57.29578, c.pose.x - f.truth.x, c.pose.y - f.truth.y,
        geometry::angleDiff(c.pose.phi, f.truth.phi), f.nees, std::sqrt(c.covariance(0, 0)),
        std::sqrt(c.covariance(1, 1)), std::sqrt(c.covariance(2, 2)), c.points_used,
        c.independent_points, c.residual_rms_m, c.residual_inflation, c.shape_widening,
        c.has_runner_up ? 1 : 0, c.runner_up_delta);
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace fieldline;
  cli::App app{
      "Layer 2 (fieldline-localize's matcher) against the truth on rendered frames whose camera "
      "differs from the configured one: NEES of each answer's covariance"};
  localize_eval::LocalizeEvalOptions options;
  std::string camera = "omni_sim", field = "msl", matcher_config;
  double min_in_band = 0.0;
  bool per_frame = false;
  app.add_option("--camera", camera, "Camera preset (the configured camera)")
      ->capture_default_str();
  app.add_option("--field", field, "Field preset")->capture_default_str();
  addEvaluationOptions(app, options);
  app.add_option("--matcher-config", matcher_config,
                 "YAML with a `matcher` section (e.g. config/fusion/default.yaml)");
  app.add_option("--min-in-band", min_in_band, "Exit 1 when the NEES in band is lower")
      ->check(cli::Range(0.0, 1.0));
  app.add_flag("--per-frame", per_frame, "One line per frame");
  FIELDLINE_CLI_PARSE(app, argc, argv);
  try {
    if (!matcher_config.empty()) {
      const config::Node root = config::Node::loadFile(matcher_config);
      options.matcher = fusion::loadMatcherParams(root.child("matcher"));
    }
    const region_tracking::SimCamera sim = region_tracking::SimCamera::load(camera, field);
    const int total = options.cameras * options.poses;
    const auto frames = localize_eval::evaluateLocalization(
        sim, region_tracking::defaultVisionParams(), options, [&](int done) {
          std::fprintf(stderr, "\r%d / %d frames", done, total);
          std::fflush(stderr);
        });
    std::fprintf(stderr, "\n");
    if (per_frame) {
      printFrames(frames);
    }
    const localize_eval::LocalizeEvalSummary summary = localize_eval::summarize(frames);
    std::printf("%s\n", localize_eval::summaryLine(summary).c_str());
    if (summary.valid == 0) {
      std::fprintf(stderr, "fieldline-eval-localize: no valid answer\n");
      return 1;
    }
    return summary.inBand() < min_in_band ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fieldline-eval-localize: %s\n", e.what());
    return 2;
  }
}
