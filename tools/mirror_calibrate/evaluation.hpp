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
  // Largest |D_fit(r, b) - D_true(r, b)| / D_true over bearings every degree and radii every
  // 0.5 px from 1 px outside the reflection to where the true distance reaches `up_to`, %.
  double distance_percent = 0.0;
  // Largest distance between the floor points both models give for the same pixel, over the
  // same range, m.
  double floor_point_m = 0.0;
};
MirrorError compareMirrors(const camera::MirrorModel& truth, const camera::MirrorModel& fitted,
                           double up_to);

}  // namespace fieldline::calibration
