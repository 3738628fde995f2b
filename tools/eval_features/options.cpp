// fieldline-eval-features' command line: the options grouped as in eval_features.hpp, and
// --config FILE to read them from a file (one "name = value" per line, names as the long options
// without the dashes, e.g. "frames = 3000").
#include "common/cli/cli.hpp"
#include "tools/eval_features/eval_features.hpp"

namespace fieldline::eval_features {
namespace {

// The path, the frames run, the checks and required rates.
void addRunOptions(cli::App& app, Options& options) {
  app.add_option("--frames", options.frames, "Frames along the scanning path")
      ->check(cli::Range(1, 10'000'000))
      ->capture_default_str();
  app.add_option("--field", options.field, "Field preset or YAML file")->capture_default_str();
  app.add_option("--camera", options.camera, "Camera preset")->capture_default_str();
  app.add_option("--count", options.count,
                 "Run only this many frames from --first-frame (0 = to the end of the path)")
      ->check(cli::Range(0, 10'000'000));
  app.add_option("--check-fresh-every", options.check_fresh_every,
                 "Every N-th frame is evaluated again by a freshly built camera, region tracker "
                 "and recogniser; exit 1 if its line points or hypotheses differ (0 = never)")
      ->check(cli::Range(0, 10'000'000));
  app.add_option("--occlusion-frames", options.occlusion_frames,
                 "Frames of the occlusion series (seed fig. 4.60); 0 = none")
      ->check(cli::Range(0, 10'000'000))
      ->capture_default_str();
  app.add_option("--first-frame", options.first_frame,
                 "Start at this frame of the --frames path (the frames before it are skipped)")
      ->check(cli::Range(0, 10'000'000));
  app.add_option("--frame", options.frame,
                 "Evaluate only this frame of the --frames path (with its clutter) in detail")
      ->check(cli::Range(0, 10'000'000));
  app.add_option("--seed", options.seed, "Seed of the clutter placement")->capture_default_str();
  app.add_option("--min-circle-rate", options.min_circle_rate,
                 "Fail (exit 1) below this centre circle rate")
      ->check(cli::Range(0.0, 1.0));
  app.add_option("--min-corner-rate", options.min_corner_rate,
                 "Fail (exit 1) below this penalty corner rate")
      ->check(cli::Range(0.0, 1.0));
  app.add_option("--pose", options.pose,
                 "Evaluate one frame at x,y,phi (m, m, rad) and print its hypotheses");
}

// The region tracker's line detector (overrides of vision_default.yaml).
void addLineOptions(cli::App& app, Options& options) {
  app.add_option("--sample-spacing", options.lines.sample_spacing,
                 "The region tracker's line sample spacing in pixels (0 = its default)")
      ->check(cli::Range(0, 64))
      ->capture_default_str();
  app.add_option("--sample-spacing-m", options.lines.sample_spacing_m,
                 "The region tracker's line sampling by distance on the field, m (0 = off, by "
                 "contour index; default: vision_default.yaml's, off with --sample-spacing)")
      ->check(cli::Range(0.0, 10.0));
  app.add_option("--sample-min-px", options.lines.sample_min_px,
                 "With --sample-spacing-m: samples at least this many pixels apart (default: "
                 "vision_default.yaml's)")
      ->check(cli::Range(0.25, 1000.0));
  app.add_option("--turn-spacing-m", options.lines.turn_spacing_m,
                 "With --sample-spacing-m: the spacing near the contour's turns, m (0 = none; "
                 "default: vision_default.yaml's)")
      ->check(cli::Range(0.0, 10.0));
  app.add_option("--turn-reach-m", options.lines.turn_reach_m,
                 "How far along the contour from a turn the turn spacing holds, m (default: "
                 "vision_default.yaml's)")
      ->check(cli::Range(0.0, 100.0));
  app.add_option("--turn-range-m", options.lines.turn_range_m,
                 "Only turns within this distance of the robot count, m (default: "
                 "vision_default.yaml's)")
      ->check(cli::Range(0.0, 100.0));
  app.add_option("--refine-range-m", options.lines.refine_range_m,
                 "The line detector's refinement around line ends and turns (sampling by index): "
                 "line points up to this far count, m (0 = off; default: vision_default.yaml's)")
      ->check(cli::Range(0.0, 100.0));
  app.add_option("--refine-min-range-m", options.lines.refine_min_range_m,
                 "Refinement: line points at least this far count, m")
      ->check(cli::Range(0.0, 100.0));
  app.add_option("--refine-samples", options.lines.refine_samples,
                 "Refinement: scans added per refined sample interval")
      ->check(cli::Range(1, 64));
  app.add_option("--refine-spacing-m", options.lines.refine_spacing_m,
                 "Refinement: at most as many scans per interval as put them this far apart on "
                 "the floor, m (0 = always --refine-samples)")
      ->check(cli::Range(0.0, 10.0));
  app.add_flag("--refine-isolated", options.lines.refine_isolated,
               "Refinement: also around line points without a neighbouring one");
  app.add_option("--refine-reach", options.lines.refine_reach,
                 "Refinement: sample intervals refined on each side of a line's end or turn")
      ->check(cli::Range(1, 16));
  app.add_option("--refine-turn", options.lines.refine_turn,
                 "Refinement: a line turns where its direction changes by more than this, rad")
      ->check(cli::Range(0.01, 3.1));
}

// The recogniser's parameters (overrides of its defaults).
void addRecognitionOptions(cli::App& app, Options& options) {
  app.add_option("--alone-side-points", options.recognition.alone_side_points,
                 "The recogniser's line_end_alone_side_points (a line end without a parallel "
                 "partner is a corner when its other line shows this many points; 0 = off; "
                 "default: the recogniser's, 2)")
      ->check(cli::Range(0, 100));
  app.add_option("--max-beyond-points", options.recognition.max_beyond_points,
                 "The recogniser's line_end_max_beyond_points (an L, not a T: at most this many "
                 "points near the corner off its two lines; -1 = not tested; default: the "
                 "recogniser's, 2)")
      ->check(cli::Range(-1, 100));
  app.add_option("--identity-max-beyond", options.recognition.identity_max_beyond,
                 "The recogniser's identity_max_beyond_points (the L test for L-corners placed "
                 "by the model check, stage 8; -1 = not tested; default: the recogniser's, 2)")
      ->check(cli::Range(-1, 100));
  app.add_option("--identity-beyond-reach", options.recognition.identity_beyond_reach,
                 "The recogniser's identity_beyond_reach (m)")
      ->check(cli::Range(0.0, 10.0));
  app.add_option("--max-unseen", options.recognition.max_unseen,
                 "The recogniser's unseen_max_stretch: a pose that puts a longer stretch of line "
                 "in clear view near the robot without a line point near it is refused (m; -1 = "
                 "not tested; default: the recogniser's)")
      ->check(cli::Range(-1.0, 100.0));
  app.add_option("--veto-margin", options.recognition.veto_margin,
                 "The recogniser's consistency_veto_margin: an accepted pose is dropped when a "
                 "refused one that implies another pose fits all points better by this share "
                 "(-1 = not tested; default: the recogniser's)")
      ->check(cli::Range(-1.0, 1.0));
  app.add_option("--unseen-range", options.recognition.unseen_range,
                 "The recogniser's unseen_range: the unseen-lines test looks this far (m; beyond "
                 "its unseen_min_range, 0.6)")
      ->check(cli::Range(0.7, 20.0));
  app.add_option("--beyond-from", options.recognition.beyond_from,
                 "The recogniser's line_end_beyond_from (m)")
      ->check(cli::Range(0.0, 10.0));
  app.add_option("--goal-shadow", options.recognition.goal_shadow,
                 "The recogniser's model_check_goal_shadow (1: points in a goal's shadow count "
                 "neither as fitting nor as not fitting; 0: they count; default: the "
                 "recogniser's, 1)")
      ->check(cli::Range(0, 1));
}

// What stands around the robot.
void addSceneOptions(cli::App& app, Options& options) {
  app.add_flag("!--no-clutter", options.scene.clutter, "No opponents or clutter");
  app.add_option("--opponents", options.scene.opponents, "Opponents around the robot per frame")
      ->check(cli::Range(0, 20))
      ->capture_default_str();
  app.add_option("--white-robots", options.scene.white_robot_share,
                 "Share of the opponents with a white body")
      ->check(cli::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--other-colour-robots", options.scene.other_colour_share,
                 "Share of the opponents with a third team's marker colour")
      ->check(cli::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--white-objects", options.scene.white_objects,
                 "White boxes beyond the border lines per frame")
      ->check(cli::Range(0, 10))
      ->capture_default_str();
  app.add_option("--people", options.scene.people, "People beyond the side lines per frame")
      ->check(cli::Range(0, 10))
      ->capture_default_str();
  app.add_option("--patches", options.scene.patches, "White patches on the carpet per frame")
      ->check(cli::Range(0, 10))
      ->capture_default_str();
  app.add_option("--orange-objects", options.scene.orange_objects,
                 "Orange objects per frame (a ball near the robot, a box beyond the border)")
      ->check(cli::Range(0, 5))
      ->capture_default_str();
}

// Where the results go.
void addOutputOptions(cli::App& app, Options& options) {
  app.add_option("--image", options.output.image,
                 "With --frame or --pose: write the camera image with the line points (PNG)");
  app.add_flag("--progress", options.output.progress,
               "Report progress every 1000 frames on stderr");
  app.add_option("--misses-csv", options.output.misses_csv,
                 "Write every penalty corner within 4 m that was not found as CSV");
  app.add_option("--circle-misses-csv", options.output.circle_misses_csv,
                 "Write every frame with the whole centre circle within 4 m in which it was not "
                 "found as CSV (occluded share, the stage reached)");
  app.add_option("--check-csv", options.output.check_csv,
                 "Write every model check (fits, verdict, error of its pose) as CSV");
  app.add_option("--out", options.output.out_dir,
                 "Directory for the detection maps and summary.json");
  app.add_option("--dump", options.output.dump,
                 "With --frame or --pose: write the frame's line points as CSV");
}

}  // namespace

void addOptions(cli::App& app, Options& options) {
  app.set_config("--config", "",
                 "Read options from this file (one 'name = value' per line, names as the long "
                 "options without the dashes); the command line overrides it");
  addRunOptions(app, options);
  addSceneOptions(app, options);
  addLineOptions(app, options);
  addRecognitionOptions(app, options);
  addOutputOptions(app, options);
}

}  // namespace fieldline::eval_features
