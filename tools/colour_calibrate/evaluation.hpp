// The must-show of issue 12, part 1, on rendered frames: under each realism setting, calibrate
// the colours from one frame at a known pose, track with the calibrated table, and score the
// line points against the field model; and the same table along a drive whose light changes.
#pragma once

#include <string>
#include <vector>

#include "services/camera/realism.hpp"
#include "services/region_tracking/colour_adaptation.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/colour_calibrate/colour_calibration.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::calibration {

struct RealismSetting {
  std::string name;
  camera::RealismParams realism;
};

// clean, noise, washed-out, colour cast, blur, vignetting, uneven light, dim, bright, all of it.
std::vector<RealismSetting> realismSettings();
// The setting of that name; throws std::invalid_argument listing the names otherwise.
RealismSetting realismSetting(const std::string& name);

// Line scores summed over several frames.
struct ScoreSum {
  int frames = 0;
  long points = 0, precise = 0;
  double visible = 0, covered = 0;
  double min_precision = 1.0, min_recall = 1.0;
  int frames_meeting = 0;  // frames with precision >= 0.9 and recall >= 0.85

  void add(const LineScore& s);
  double precision() const { return points > 0 ? double(precise) / double(points) : 0.0; }
  double recall() const { return visible > 0 ? covered / visible : 0.0; }
};

struct SettingResult {
  std::string setting;
  geometry::Pose2 pose;
  Calibration calibration;
  Coverage coverage;
  ScoreSum score;
};

// Renders one frame at `pose` under `setting`, calibrates from it (base table: the camera's),
// then tracks `frames` frames at that pose (sensor noise differs per frame) with the calibrated
// table and scores the line points of every frame after the first two. With `shipped`, the
// camera's own table is used instead of calibrating (the comparison). The renderer's realism
// is restored to identity afterwards.
SettingResult evaluateSetting(region_tracking::SimCamera& sim, const RealismSetting& setting,
                              const geometry::Pose2& pose, int frames, const FitParams& params,
                              bool shipped = false);

struct DriveResult {
  ScoreSum score;
  double light_from = 1.0, light_to = 1.0;
  // With adaptation: the light gain applied at the end, its range over the drive (relative to
  // the reference), and how often the table was rebuilt.
  double final_gain = 1.0, min_gain = 1.0, max_gain = 1.0;
  long rebuilds = 0;
};

// Drives `frames` frames around the field (1.5 m/s, turning 0.5 rad/s) under `setting` with its
// light factor changing linearly from light_from to light_to (the light ramp), tracking with a
// copy of `table` (lines every 3rd frame), scoring every line frame. With `adaptation.enabled`,
// green and white follow the light (ColourAdaptation over the tracked green, as the node does).
// `vision`: the tracker's and detectors' parameters (defaultVisionParams()).
DriveResult evaluateDrive(
    region_tracking::SimCamera& sim, const RealismSetting& setting,
    const camera::ColourTable& table, int frames, double light_from, double light_to,
    const region_tracking::ColourAdaptationParams& adaptation = {},
    const region_tracking::VisionParams& vision = region_tracking::defaultVisionParams());

}  // namespace fieldline::calibration
