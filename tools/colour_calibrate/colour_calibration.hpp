// Colour calibration from frames at a known pose on a known field (issue 12, part 1), and the
// ground truth the line detector is scored against.
//
// No hand-drawn masks: the field model, projected through the mirror model from the known pose,
// says which pixels should be carpet and which line. Both masks are eroded (by pixels of the
// mirror's local footprint and by metres of pose uncertainty) so that calibration errors and
// blurred edges do not leak into the samples. Green is fitted in YUV with robust percentiles, in
// bands of luma (a carpet under uneven light is a cone in YUV: its chroma shrinks toward grey as
// it gets darker, so one box per luma band hugs it tighter than one box); white from the line
// pixels that the green boxes do not claim. The other classes come from a base table (or from
// user masks painted over a frame). The result is a box table as common/camera reads it.
//
// Plain library: no LCM, no clock.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/line_points.hpp"

namespace fieldline::calibration {

// What the field model says about a pixel seen from a pose.
enum class Expected : std::uint8_t {
  kNone = 0,   // don't-touch zone, or no floor point
  kCarpet,     // green carpet (not a line)
  kLine,       // on a painted line
  kOffCarpet,  // floor beyond the carpet
};

struct PredictedPixel {
  Expected truth = Expected::kNone;
  // Inside the eroded masks: safe samples for the fit.
  bool carpet_core = false;
  bool line_core = false;
};

struct MaskParams {
  // Erosion of the line mask, px of the floor footprint across the line (0.5: the whole pixel
  // lies on the paint), and of the carpet mask (away from lines, the carpet's edge and the goal
  // lines), px of the coarser footprint and m (pose uncertainty).
  double line_margin_px = 0.5;
  double carpet_margin_px = 3.0;
  double carpet_margin_m = 0.08;
  // Line samples only where the line is this close (m): far lines are a pixel wide and mixed.
  double max_line_distance = 4.0;
  // Carpet samples only this close (m): far carpet comes from coarse, blended texture.
  double max_carpet_distance = 6.0;
  // Around the penalty marks nothing is sampled as carpet, m.
  double mark_radius = 0.25;
};

// Per pixel (row-major, width x height) of the mirror's image: what the field model predicts
// from `pose`.
std::vector<PredictedPixel> predictPixels(const camera::MirrorModel& mirror,
                                          const field::FieldModel& field,
                                          const geometry::Pose2& pose, const MaskParams& params);

struct FitParams {
  MaskParams masks;
  // Robust range of each channel: these percentiles of the samples, widened by margin_levels.
  double low_percentile = 0.5;
  double high_percentile = 99.5;
  int margin_levels = 4;
  // Green's (first in the table, so it must not reach into white): tighter.
  double green_low_percentile = 1.0;
  double green_high_percentile = 99.0;
  // Boxes per class: one per band of luma (geometric), each holding the chroma the class has at
  // that luma.
  int green_bands = 8;
  int white_bands = 4;
  // White's lower luma bound: at least this percentile of the white samples (blurred edges
  // contaminate the low end).
  double white_low_percentile = 2.0;
  // Light the table is made for, relative to the calibration frames' light (low <= 1 <= high):
  // a change of light is a gain on R, G and B, which scales luma and the chroma's distance from
  // grey together, so each class is fitted as a cone in YUV (chroma / luma ratios) over this
  // range of luma. A robot that drives from the bright to the dark side of a hall keeps its
  // classes; {1, 1} fits the calibration light only.
  std::array<double, 2> light_range{0.65, 1.55};
  // Fewer samples than this is an error (the frame does not show enough of the class).
  int min_samples = 200;
  int min_line_samples = 40;
};

// A frame and the pose it was taken at.
struct PosedFrame {
  camera::FrameView frame;
  geometry::Pose2 pose;
};

// Samples of a class painted by the user (nonzero pixels of a mask over a frame). kUnknown:
// pixels that are neither carpet nor line nor any class (kept out of the samples only).
struct UserMask {
  camera::ColourClass colour = camera::ColourClass::kOrange;
  camera::FrameView frame;
  std::vector<std::uint8_t> mask;  // width x height, nonzero = sample
};

struct ClassFit {
  camera::ColourClass colour = camera::ColourClass::kUnknown;
  std::vector<camera::YuvBox> boxes;
  int samples = 0;
};

struct Calibration {
  // Calibrated classes (green and white first, then user-mask classes), then the base table's
  // boxes of every other class: the table to write.
  std::vector<camera::YuvBox> boxes;
  std::vector<ClassFit> fits;
  // Median (Y, U, V) of the carpet samples: the colour adaptation's reference.
  std::array<double, 3> carpet_median{0, 0, 0};
};

// Fits green and white from `frames` (all of the mirror's size) and any user masks (pixels
// painted over a frame, and 3 px around them, are left out of that frame's carpet and line
// samples: a ball or robot on the carpet is not carpet); keeps the
// base table's boxes of the classes not fitted. Throws std::runtime_error naming the class when a
// class has fewer samples than the minimum, std::invalid_argument for frames of another size.
Calibration calibrate(const camera::MirrorModel& mirror, const field::FieldModel& field,
                      const std::vector<PosedFrame>& frames, const std::vector<UserMask>& masks,
                      const std::vector<camera::YuvBox>& base, const FitParams& params);

// Luma at percentile p (0..100) of the samples.
int percentileOfLuma(const std::vector<camera::Yuv>& samples, double p);

// How well a table separates what the field model predicts, over frames at known poses.
struct Coverage {
  // Shares of the predicted pixels of each kind (lines within max_line_distance) by class.
  double carpet_green = 0, carpet_white = 0, line_white = 0, line_green = 0, off_carpet_green = 0;
  long carpet_pixels = 0, line_pixels = 0, off_carpet_pixels = 0;
};
Coverage measureCoverage(const camera::MirrorModel& mirror, const field::FieldModel& field,
                         const std::vector<PosedFrame>& frames, const camera::ColourTable& table,
                         const MaskParams& params);

// The colour YAML common/camera reads (loadColourTable), with a comment header.
std::string colourTableYaml(const std::vector<camera::YuvBox>& boxes, const std::string& comment);

// Line points scored against the field model (the must-show of issue 12).
struct LineScore {
  int points = 0;
  // Points within `tolerance_px` of a pixel the model says is line.
  int precise = 0;
  double precision = 0.0;
  // Model line length (centre lines, m of floor) visible within max_distance, and the part of it
  // a sequence of line points passes within tolerance_px of (in the image).
  double visible_length = 0.0;
  double covered_length = 0.0;
  double recall = 0.0;
};

struct ScoreParams {
  double tolerance_px = 3.0;
  double max_distance = 4.0;
  double sample_step = 0.01;
};

LineScore scoreLinePoints(const camera::MirrorModel& mirror, const field::FieldModel& field,
                          const geometry::Pose2& pose, const perception::LinePoints& lines,
                          const ScoreParams& params);

}  // namespace fieldline::calibration
