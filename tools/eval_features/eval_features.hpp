// fieldline-eval-features as a library: renders frames at poses over the whole field (a scanning
// path with the robot turning through all headings, opponents and clutter around it), runs the
// region tracker and the feature recogniser on each, and compares every pose hypothesis with the
// true pose and its point-symmetric twin. Writes detection maps per feature kind (seed fig.
// 4.59), an occlusion series of the centre circle (fig. 4.60) and a JSON summary, and ends with
//   frames=N false_hypotheses=F circle_rate=A corner_rate=B pos_median_m=P heading_median_deg=H
//
// Every frame is reproducible on its own: its clutter comes from (seed, frame), the sensor noise
// from the frame number, and the region tracker starts afresh on each frame.
#pragma once

#include <cstdint>
#include <string>

namespace fieldline::cli {
class App;
}

namespace fieldline::eval_features {

// Overrides of the region tracker's line detector (vision_default.yaml's values otherwise).
struct LineOverrides {
  // The line sample spacing (px); 0 = its default.
  int sample_spacing = 0;
  // Sampling by distance on the field (m; 0 = off; negative = the default of
  // vision_default.yaml, or off when sample_spacing is given), and its minimum pixel spacing
  // (0 = the default).
  double sample_spacing_m = -1.0;
  double sample_min_px = 0.0;
  // Denser near the contour's turns (m; negative = the default), and the reach (m; negative =
  // the default).
  double turn_spacing_m = -1.0;
  double turn_reach_m = -1.0;
  double turn_range_m = -1.0;
  // The refinement (sampling by index; negative = the default's).
  double refine_range_m = -1.0, refine_min_range_m = -1.0, refine_turn = -1.0,
         refine_spacing_m = -1.0;
  int refine_samples = 0, refine_reach = 0;
  bool refine_isolated = false;
};

// Overrides of the recogniser's parameters (RecognitionParams' defaults otherwise).
struct RecognitionOverrides {
  // line_end_alone_side_points (negative = its default).
  int alone_side_points = -1;
  // line_end_max_beyond_points (below -1 = its default) and model_check_goal_shadow (0 off, 1 on,
  // -1 its default).
  int max_beyond_points = -2;
  int goal_shadow = -1;
  // identity_max_beyond_points (below -1 = its default), identity_beyond_reach and
  // line_end_beyond_from (negative = their defaults).
  int identity_max_beyond = -2;
  double identity_beyond_reach = -1.0;
  double beyond_from = -1.0;
  // unseen_max_stretch and unseen_range (below -1 / 0: its defaults).
  double max_unseen = -2.0;
  double unseen_range = 0.0;
  // consistency_veto_margin (below -1: its default).
  double veto_margin = -2.0;
};

// What stands around the robot in each frame (with clutter off, nothing).
struct SceneOptions {
  bool clutter = true;
  int opponents = 3;
  double white_robot_share = 0.3;   // opponents with a white body
  double other_colour_share = 0.3;  // opponents with a marker of a third team's colour
  int white_objects = 2;            // white boxes beyond the field's border lines
  int people = 2;                   // people standing beyond the side lines
  int patches = 2;                  // flat white patches on the carpet within 5 m
  int orange_objects = 1;           // a ball within 5 m, an orange box beyond the border
};

// Where the results go (each empty = not written).
struct OutputOptions {
  std::string out_dir;  // detection maps, occlusion chart, summary.json
  std::string image;    // with --frame/--pose: the camera image with the line points
  std::string dump;     // with --frame/--pose: the line points as CSV
  std::string check_csv;
  std::string misses_csv;
  std::string circle_misses_csv;
  bool progress = false;
};

struct Options {
  int frames = 3000;
  std::string field = "msl";
  std::string camera = "omni_sim";
  std::uint32_t seed = 1;
  // Only the frames from first_frame on of the --frames path (to look into a part of a long run),
  // `count` of them (0 = to the end of the path).
  int first_frame = 0;
  int count = 0;
  // One frame in detail: a frame of the path, or a pose (x,y,phi).
  int frame = -1;
  std::string pose;
  // Every this many frames, the frame is also evaluated by a freshly built pipeline (camera,
  // region tracker, recogniser) and must give the same line points and hypotheses (0 = never).
  int check_fresh_every = 0;
  // Frames of the centre circle's occlusion series (0 = none).
  int occlusion_frames = 0;
  // Required rates (negative = none).
  double min_circle_rate = -1.0;
  double min_corner_rate = -1.0;
  LineOverrides lines;
  RecognitionOverrides recognition;
  SceneOptions scene;
  OutputOptions output;
};

// The command line (and --config FILE) into `options`.
void addOptions(cli::App& app, Options& options);

// Runs the evaluation: 0 when no hypothesis is false, every fresh check agrees and the required
// rates are met; 1 otherwise; 2 for bad options.
int run(const Options& options);

}  // namespace fieldline::eval_features
