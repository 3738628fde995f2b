// Colour calibration from the frames alone (issue 30, item 2; docs/calibration.md): no pose, no
// chroma prior. The floor is the dominant colour where the mirror shows floor near the robot;
// lines are narrow bright ridges on it (floor on both sides, about a line's width for their
// distance); the ball and the robots are what is neither, found once the frames' line points
// have been fitted to the field (the ball: a compact blob of a ball's size for its distance,
// inside the field, at one field position in every frame; robots: dark blobs standing on the
// field). The classes are fitted relative to the white point (the lines' chroma, which carries
// any colour cast) as cones that hold when the light changes, into a full lookup table.
//
// The procedure ends with its own check: the tracker's line points with the new table, fitted to
// the field (fusion's global search), with the figures; a table that gives no line points, lines
// not brighter than the floor, or points that do not fit the field are refused.
//
// Plain library: no bus, no clock.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/line_points.hpp"

namespace fieldline::calibration {

struct ImageFitParams {
  // The floor annulus: floor distances (m) where the robot's surroundings are floor.
  double floor_from_m = 0.5;
  double floor_to_m = 3.5;
  // The dominant chroma must hold at least this share of the annulus' pixels.
  double min_floor_share = 0.3;
  // Ridges: a line is at least this many times as bright as the floor beside it, and at most
  // this many times a line's width in the image (plus blur_px) wide.
  double min_line_ratio = 1.18;
  double max_width_factor = 1.8;
  double blur_px = 3.0;
  // Lines further than this are not sampled, m.
  double max_line_distance = 5.0;
  // Light the table holds for, relative to the frames' (a gain on R, G and B).
  std::array<double, 2> light_range{0.65, 1.5};
  int min_floor_samples = 500;
  int min_line_samples = 60;
  // Ball search: blobs whose area is within these factors of a ball's image at their distance
  // (its surface projected through the mirror).
  double ball_area_low = 0.3;
  double ball_area_high = 2.5;
  // The check: a frame's line points fit the field when this share lies within fit_distance.
  double fit_distance_m = 0.15;
  double min_fit_share = 0.7;
  int min_line_points = 25;
};

// The floor's colour as found.
struct FloorReport {
  std::array<double, 3> median{0, 128, 128};  // Y, U, V
  double chroma_sigma = 0.0;                  // levels
  double share = 0.0;                         // of the annulus' pixels
  std::array<double, 2> luma{0, 0};           // p1, p99
};

struct ClassSamples {
  std::vector<camera::Yuv> floor, line, ball, robot;
};

// What the calibration found and the table it made (before the check).
struct ImageCalibration {
  FloorReport floor;
  std::array<double, 2> white_point{128, 128};  // the lines' chroma (U, V)
  std::array<double, 2> line_luma{0, 0};        // p5, p95 of the line samples
  // Where floor and white share chroma: floor up to luma_boundary, white from white_from.
  double luma_boundary = 0.0;
  double white_from = 0.0;
  ClassSamples samples;
  int ridges = 0;       // ridge crossings found
  int line_ridges = 0;  // of them accepted as lines
  bool ball_found = false;
  // Pixels of the ball's blobs left out of its class as the carpet's or the lines' colours
  // (a ball lying on a line); samples.ball holds the others.
  int ball_samples_refused = 0;
  geometry::Vec2 ball_field = geometry::Vec2::Zero();  // where the ball lies, field frame
  int ball_frames = 0;
  bool robots_found = false;
  camera::ColourTable table;
};

// One frame's result of the check.
struct FrameCheck {
  int line_points = 0;
  bool localized = false;
  geometry::Pose2 pose;
  double median_cm = 0.0;        // median distance of the points to the field's lines at the pose
  double fit_share = 0.0;        // share within fit_distance_m
  perception::LinePoints lines;  // the tracker's line points
  std::vector<bool> on_line;     // per point: within fit_distance_m at the pose
};

struct TableCheck {
  std::vector<FrameCheck> frames;
  int line_points = 0;
  double fit_share = 0.0;  // over all frames
  // Median luma of the pixels classified white and green, over the frames.
  double white_luma = 0.0, green_luma = 0.0;
  // Why the table must not be written (empty: it may).
  std::vector<std::string> problems;
};

// Floor, lines and (with poses from a first check) ball and robots, and the table. `poses`:
// empty, or one per frame (from checkTable of a first table; nullopt: that frame is not used for
// the ball and robots). Throws Refusal
// (tools/calibration_common/staged_output.hpp) when the frames show no dominant floor colour or
// no bright ridges on it, std::invalid_argument for frames of another size than the mirror's.
ImageCalibration calibrateFromImages(const camera::MirrorModel& mirror,
                                     const field::FieldModel& field,
                                     const std::vector<camera::FrameView>& frames,
                                     const std::vector<std::optional<geometry::Pose2>>& poses,
                                     const ImageFitParams& params);

// Tracks every frame with the table (the region tracker's default parameters), fits each
// frame's line points to the field (global search) and measures what the table does.
TableCheck checkTable(const camera::MirrorModel& mirror, const field::FieldModel& field,
                      const std::vector<camera::FrameView>& frames,
                      const camera::ColourTable& table, const ImageFitParams& params);

// The whole procedure: a first table (floor and lines), its check (which gives each frame's pose
// where its line points fit the field), the ball and robots from the frames that fitted, the
// final table and its check. Throws Refusal like calibrateFromImages; the check's problems are
// the caller's to act on.
struct FramesCalibration {
  ImageCalibration calibration;
  TableCheck check;
  int posed = 0;  // frames that fitted the field with the first table
};
FramesCalibration calibrateColours(const camera::MirrorModel& mirror,
                                   const field::FieldModel& field,
                                   const std::vector<camera::FrameView>& frames,
                                   const ImageFitParams& params);

// The tracker's line points of one frame with a table (three passes, lines on the last).
perception::LinePoints trackLines(const camera::MirrorModel& mirror,
                                  const camera::ColourTable& table, const camera::FrameView& frame);

}  // namespace fieldline::calibration
