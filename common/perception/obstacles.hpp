// Obstacles (black robots) seen in one camera frame (VISION_OBSTACLES without LCM): what the
// region tracker finds and what fusion and teamcomm read.
#pragma once

#include <cstdint>
#include <vector>

namespace fieldline::perception {

struct ObstacleSighting {
  // Bearing of the centre of the obstacle's angular extent, robot frame, rad CCW from x.
  double bearing = 0.0;
  // Distance from the robot to the obstacle's nearest point on the floor, m.
  double distance = 0.0;
  // Angular width as seen from the robot, rad.
  double angular_width = 0.0;
  // Width across the viewing ray at `distance`, m.
  double width = 0.0;
  // Nearest floor point of the obstacle, robot frame (x forward, y left), m.
  double x = 0.0;
  double y = 0.0;
};

struct ObstacleSightings {
  // Exposure time of the frame, µs since the epoch on this robot's clock.
  std::int64_t utime = 0;
  std::vector<ObstacleSighting> obstacles;
};

}  // namespace fieldline::perception
