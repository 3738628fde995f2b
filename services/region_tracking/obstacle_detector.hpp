// Obstacles in regions of the obstacle colour (black robots): bearing, angular width and the
// distance of their foot on the floor.
#pragma once

#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/mirror_model.hpp"
#include "services/region_tracking/contours.hpp"

namespace fieldline::region_tracking {

struct ObstacleParams {
  camera::ColourClass colour = camera::ColourClass::kBlack;
  // Regions smaller than this are ignored, cells.
  int min_cells = 4;
};

struct Obstacle {
  // Bearing of the centre of the obstacle's angular extent, robot frame, rad.
  double bearing = 0;
  // Distance to the nearest point on the floor, m.
  double distance = 0;
  double angular_width = 0;
  // Width across the viewing ray at `distance`, m.
  double width = 0;
  // Nearest floor point, robot frame, m.
  double x = 0, y = 0;
};

class ObstacleDetector {
 public:
  ObstacleDetector(const camera::MirrorModel& mirror, const ObstacleParams& params);
  // One obstacle per outer contour of the obstacle colour.
  void detect(const ContourSet& contours, std::vector<Obstacle>& out) const;

 private:
  const camera::MirrorModel& mirror_;
  ObstacleParams params_;
};

}  // namespace fieldline::region_tracking
