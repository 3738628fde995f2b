// Mirror calibration from field lines at an unknown pose (issue 30, item 1;
// docs/mirror_calibration.md section 5): from frames of the field, the field model and the image
// size, find the mirror (centre, distance function, the axis offset where the data pins it) and
// the robot's pose in every frame together.
//
// Stages:
//   1. The mirror's rim (where the image turns dark beyond the mirror) gives the centre's first
//      guess when it is visible; else the base camera's centre, scaled to the image.
//   2. Bright ridges of luma in every frame (tools/calibration_common/ridges.hpp): line pixels
//      whatever the carpet's colour.
//   3. Search: candidate mirrors (the base distance function stretched in radius and in
//      distance) times robot poses over the whole field (a lattice of positions and headings,
//      scored on a distance grid of the field's lines with a truncated cost, the best refined):
//      the candidate whose best poses fit all frames best wins.
//   4. Frames taken at one spot (the robot turned on the spot) share one position: the poses
//      found for them are linked (the field's symmetric twin chosen to agree).
//   5. Joint fit: centre, the image radii of the distance knots, every pose (a spot's position
//      and each frame's heading) and, when frames at one spot turned far enough, the axis offset:
//      robust Levenberg-Marquardt on each line pixel's distance across its nearest field line,
//      associations renewed each round with a gate that shrinks while the range of distances
//      used grows outward (the near field first, where any start is closest).
//   6. The offset is kept only when its standard deviation (from the fit's curvature, inflated
//      for neighbouring pixels' correlated errors) is below the limit; else it is fixed at 0 and
//      the report says the data does not pin it. Each bearing sector then gets its own radii
//      (a tilted camera, a mirror that is not round), held near the common ones by a prior.
//
// Plain library: no bus, no clock.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "tools/calibration_common/floor_colour.hpp"
#include "tools/calibration_common/grey_image.hpp"
#include "tools/calibration_common/ridges.hpp"

namespace fieldline::calibration {

// One frame for the calibration: its luma, the spot it was taken at (frames with the same spot
// >= 0 show the robot turned on one spot; -1: a frame on its own) and, when known, its pose.
struct UnposedFrame {
  GreyImage image;
  int spot = -1;
  std::optional<geometry::Pose2> pose;
  std::string name;  // for messages
  // The frame's colours (one per pixel), when it has them: lines are ridges with the floor's
  // colour on both sides. Empty: luma only.
  std::vector<camera::Yuv> colour;
};

enum class OffsetMode { kAuto, kFit, kZero };

struct FitRound {
  double max_distance_m = 3.0;  // line pixels up to this floor distance are used
  double gate_px = 6.0;         // and only within this many pixels of their nearest line
};

struct PoseFreeParams {
  RidgeParams ridges;
  // Candidate mirrors: the base distance function D(r) becomes s * D(r / k) for every radius
  // scale k and distance scale s.
  std::vector<double> radius_scales{0.86, 0.93, 1.0, 1.08, 1.16};
  std::vector<double> distance_scales{0.55, 0.63, 0.72, 0.82, 0.92, 1.0,
                                      1.1,  1.22, 1.36, 1.52, 1.7};
  // The pose lattice of the search, m and degrees; the points it is scored with (line pixels up
  // to search_max_distance under the candidate) and their truncation distance, m.
  double search_position_step = 0.5;
  double search_heading_step_deg = 5.0;
  int search_points = 80;
  double search_max_distance = 4.5;
  double search_truncation = 0.3;
  // Frames the candidates are first compared on, and candidates kept for all frames.
  int search_frames = 2;
  int search_survivors = 6;
  // Knots of the distance function at these fractions of the usable image radius (denser
  // toward the rim, where the distance grows fastest); their floor distances are fitted. The
  // table ends at the last knot with min_knot_support line pixels since the one before, or
  // before two knots in a row without (beyond the third), and at most at max_table_distance.
  std::vector<double> knot_fractions{0.12, 0.22, 0.32, 0.42, 0.51,  0.6,   0.68, 0.75,
                                     0.81, 0.86, 0.9,  0.93, 0.955, 0.975, 0.99};
  int min_knot_support = 25;
  double max_table_distance = 9.0;
  // Weight of the distance function's smoothness (second difference of the log of the metres per
  // pixel between knots), px per unit.
  double smoothness = 3.0;
  std::vector<FitRound> rounds{{2.5, 10.0}, {3.0, 7.0}, {3.5, 5.0}, {4.5, 4.0},
                               {5.5, 3.0},  {6.5, 2.5}, {8.0, 2.0}, {8.0, 1.5}};
  // Priors of the joint fit: the tilt's size, px, and how far the mirror's axis may lie from the
  // centre of its rim in the image (where the rim is seen), px.
  double tilt_prior_px = 3.0;
  double rim_prior_px = 1.0;
  double huber_px = 0.7;
  int iterations = 12;
  OffsetMode offset = OffsetMode::kAuto;
  // An offset is kept only with a standard deviation below this per axis, m.
  double offset_sigma_limit = 0.01;
  int sectors = 8;
  double sector_prior_px = 1.0;
  double radius_step = 2.0;
  // Print the search's candidates and every round's state to stderr.
  bool verbose = false;
};

struct FramePose {
  std::string name;
  int spot = -1;
  geometry::Pose2 pose;  // the robot's centre, field frame
  geometry::Pose2 twin;  // the field's symmetric twin (fits exactly as well)
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();  // x, y (m), phi (rad), 1 sigma
  int points = 0;  // line pixels of this frame used in the last round
  double rms_px = 0.0;
  // Share of this frame's line pixels (within the final range) that lie on a field line.
  double on_lines = 0.0;
};

struct SearchReport {
  double radius_scale = 1.0, distance_scale = 1.0;
  double score = 0.0;      // mean truncated cost of the winner (0 perfect, 1 nothing fits)
  double runner_up = 0.0;  // of the best other candidate
  int candidates = 0;
  // Refusals of non-finite robot-frame points (a pixel without a floor distance or bearing),
  // never measured against the field: counted at each use, so a point used by several steps of
  // the search counts once per step.
  int non_finite_points = 0;
};

struct PoseFreeCalibration {
  camera::MirrorParams mirror;  // what would be written
  FloorColour floor;            // the floor's colour near the robot
  bool rim_found = false;
  camera::Vec2 rim_centre = camera::Vec2::Zero();
  double rim_radius = 0.0;
  SearchReport search;
  std::vector<FramePose> frames;
  // The axis offset and its covariance (m^2); `offset_fitted` false when it was held at 0.
  camera::Vec2 offset = camera::Vec2::Zero();
  Eigen::Matrix2d offset_covariance = Eigen::Matrix2d::Zero();
  bool offset_fitted = false;
  std::string offset_note;
  // Centre's standard deviation, px; the tilt (image radius shift along +u and +v), px.
  double centre_sigma_px = 0.0;
  camera::Vec2 tilt_px = camera::Vec2::Zero();
  std::vector<double> knot_radii, knot_distances;
  std::vector<int> knot_support;
  double table_end_m = 0.0;  // the farthest supported knot
  int ridge_pixels = 0;      // found in all frames
  int used = 0;              // on lines in the last round
  double rms_px = 0.0, rms_cm = 0.0;
  double on_lines = 0.0;  // used / ridge pixels within the final range
  // Median of the near line pixels' ridge width over the width the field's line has in the
  // image there (about 1 for frames of this field), and how many pixels it is over.
  double line_width_ratio = 0.0;
  int width_samples = 0;
};

// The base camera's parameters for an image of another size: every pixel quantity scaled by the
// ratio of the smaller sides, the centre kept at the same place relative to the image's middle.
camera::MirrorParams scaleMirrorTo(const camera::MirrorParams& base, int width, int height);

// Stage 1: the circle where the image turns dark beyond the mirror, searched outward from
// `guess` between min_radius and max_radius. nullopt when too few rays show it.
struct Rim {
  camera::Vec2 centre = camera::Vec2::Zero();
  double radius = 0.0;
  int rays = 0;
};
std::optional<Rim> findMirrorRim(const GreyImage& image, const camera::Vec2& guess,
                                 double min_radius, double max_radius);

// Stages 1-6. `base` is the camera preset (any image size: it is scaled to the frames'). Throws
// Refusal (staged_output.hpp) when the frames do not support a calibration (no lines, nothing
// fits the field) and std::invalid_argument for unusable input (no frames, frames of different
// sizes).
PoseFreeCalibration calibrateAtUnknownPose(const std::vector<UnposedFrame>& frames,
                                           const field::FieldModel& field,
                                           const camera::MirrorParams& base,
                                           const PoseFreeParams& params);

// Why a calibration is not good enough to write (empty: it is): rms above 1 px, fewer than 60 %
// of the ridge pixels in range on the lines, a frame with fewer than 60 line pixels or 45 % on
// lines (a frame that does not show the field), lines of another width than the field's (0.85 to
// 1.25 times), a table that reaches less than 3 m.
std::vector<std::string> weaknesses(const PoseFreeCalibration& c, const std::string& field_name);

}  // namespace fieldline::calibration
