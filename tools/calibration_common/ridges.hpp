// Bright ridges of luma in any direction (issue 30): what field lines, painted rings and tape look
// like in an omni-directional frame whatever the carpet's colour. A pixel is on a ridge when it is
// brighter than the image on both sides of it along some direction (at one of several distances,
// since a line near the robot is many pixels wide and a far one is one pixel). The ridge's centre
// is the brightness-weighted centre of its profile above half height, so each crossing of a line
// gives one sub-pixel point.
//
// Plain library: no bus, no clock.
#pragma once

#include <vector>

#include "common/camera/mirror_model.hpp"
#include "tools/calibration_common/grey_image.hpp"

namespace fieldline::calibration {

struct RidgeParams {
  // Distances from the centre at which the two flanks are sampled, px: a ridge of half-width w
  // is found at every distance above about w + 1.
  std::vector<double> half_widths{1.5, 2.5, 4.0, 6.0, 9.0};
  // The centre must be this many grey levels brighter than the brighter flank, and this many
  // times as bright.
  double min_contrast = 12.0;
  double min_ratio = 1.12;
  // Pixels searched: an annulus around `centre`, px.
  camera::Vec2 centre = camera::Vec2::Zero();
  double min_radius = 0.0;
  double max_radius = 1e9;
};

struct Ridge {
  camera::Vec2 pixel = camera::Vec2::Zero();    // sub-pixel centre across the ridge
  camera::Vec2 normal = camera::Vec2::UnitX();  // the direction it was crossed in (unit)
  double half_width = 0.0;                      // the flank distance that found it, px
  double width = 0.0;                           // extent above half height, px
  double peak = 0.0;                            // luma at the centre (lightly smoothed)
  double flank = 0.0;                           // luma of the brighter flank
};

// Every ridge crossing in the annulus: one point per crossing of a ridge along the direction
// across which it is strongest (of four: rows, columns, both diagonals).
std::vector<Ridge> findRidges(const GreyImage& image, const RidgeParams& params);

}  // namespace fieldline::calibration
