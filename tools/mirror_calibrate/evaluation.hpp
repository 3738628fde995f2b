// Mirror calibration measured on rendered frames (issue 12, part 3): a ring carpet drawn through
// a known mirror model (with its centre and axis offset) and the realism knobs of the simulated
// camera, calibrated, and the result compared with the model that drew it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/field/field_model.hpp"
#include "services/camera/realism.hpp"
#include "services/camera/sim_renderer.hpp"
#include "tools/mirror_calibrate/mirror_calibration.hpp"

namespace fieldline::calibration {

struct RingCarpet {
  // Ring distances from the robot's centre, m, and the width of the painted rings, m.
  std::vector<double> distances{0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0};
  double ring_width = 0.08;
  // Luma of the carpet and of the rings (before the realism knobs), levels.
  double carpet_luma = 80.0;
  double ring_luma = 225.0;
  // Sub-samples per pixel side (anti-aliasing).
  int supersample = 4;
};

// The carpet seen through `mirror` (rings centred on the robot's centre, so an axis offset
// shows), with the realism knobs applied to frame `frame_number`.
GreyImage renderRingCarpet(const camera::MirrorModel& mirror, const RingCarpet& carpet,
                           const camera::RealismParams& realism, std::uint64_t frame_number);

// Field frames at `poses` rendered by the simulated camera through `mirror` (luma only), with the
// realism knobs; for the calibration from field lines.
std::vector<PosedImage> renderFieldFrames(const camera::MirrorModel& mirror,
                                          const field::FieldModel& field,
                                          const camera::RenderParams& render,
                                          const std::vector<geometry::Pose2>& poses,
                                          const camera::RealismParams& realism);

struct MirrorError {
  double centre_px = 0.0;
  double offset_m = 0.0;
  // Over every pixel (quarter-pixel steps) that the true model shows in its useful zone within
  // `up_to` m of the axis: the largest relative difference of the floor distance from the axis
  // that the two models give for it (only where the true one is at least `from`), %; 1e9 where
  // the fitted model gives none.
  double distance_percent = 0.0;
  // The largest distance between the floor points (robot frame) both models give for the same
  // pixel, m.
  double floor_point_m = 0.0;
};
MirrorError compareMirrors(const camera::MirrorModel& truth, const camera::MirrorModel& fitted,
                           double up_to, double from = 0.0);

}  // namespace fieldline::calibration
