#include "services/region_tracking/obstacle_detector.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include "services/region_tracking/detector_pixels.hpp"
#include "services/region_tracking/frame_classifier.hpp"

namespace fieldline::region_tracking {

using detail::kCornerToPixel;

ObstacleDetector::ObstacleDetector(const camera::MirrorModel& mirror, const ObstacleParams& params)
    : mirror_(mirror), params_(params) {}

void ObstacleDetector::detect(const ContourSet& contours, std::vector<Obstacle>& out) const {
  out.clear();
  const ClassId black = classIdOf(params_.colour);
  for (const Contour& contour : contours.contours) {
    if (contour.class_id != black || !contour.outer ||
        contour.signed_cell_area < params_.min_cells) {
      continue;
    }
    // The foot of an object standing on the floor is its point nearest the image centre;
    // its angular extent is the spread of bearings around the first point.
    camera::Vec2 nearest;
    double nearestRadius = std::numeric_limits<double>::infinity();
    double firstBearing = 0, minOffset = 0, maxOffset = 0;
    bool first = true;
    for (const ContourPoint& p : contours.pointsOf(contour)) {
      const camera::Vec2 pixel(p.x + kCornerToPixel, p.y + kCornerToPixel);
      const double bearing = mirror_.bearingOf(pixel);
      if (first) {
        firstBearing = bearing;
        first = false;
      }
      const double offset = std::remainder(bearing - firstBearing, 2 * std::numbers::pi);
      minOffset = std::min(minOffset, offset);
      maxOffset = std::max(maxOffset, offset);
      const double radius = mirror_.radiusOf(pixel);
      if (radius < nearestRadius) {
        nearestRadius = radius;
        nearest = pixel;
      }
    }
    const std::optional<camera::Vec2> foot = mirror_.imageToRobot(nearest);
    if (!foot) continue;
    Obstacle obstacle;
    obstacle.distance = foot->norm();
    obstacle.x = foot->x();
    obstacle.y = foot->y();
    obstacle.angular_width = maxOffset - minOffset;
    obstacle.bearing =
        std::remainder(firstBearing + 0.5 * (minOffset + maxOffset), 2 * std::numbers::pi);
    obstacle.width = 2.0 * obstacle.distance * std::tan(0.5 * obstacle.angular_width);
    out.push_back(obstacle);
  }
}

}  // namespace fieldline::region_tracking
