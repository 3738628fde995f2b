#include "teamcomm/field_obstacles.hpp"

#include <algorithm>
#include <cmath>

#include "common/geometry/geometry.hpp"

namespace fieldline::teamcomm {

namespace {
constexpr double kMinObstacleRadius_m = 0.05;
}

std::vector<PacketObstacle> obstaclesInField(const perception::ObstacleSightings& seen,
                                             const perception::RobotEstimate& pose,
                                             std::int64_t max_gap_us) {
  std::vector<PacketObstacle> out;
  using perception::LocalizationStatus;
  if (pose.status != LocalizationStatus::kTracking &&
      pose.status != LocalizationStatus::kOdometryOnly) {
    return out;
  }
  const std::int64_t gap = seen.utime - pose.utime;
  if (gap > max_gap_us || gap < -max_gap_us || !geometry::isFinite(pose.pose)) return out;
  const double dt = static_cast<double>(gap) * 1e-6;
  const geometry::Pose2 at{pose.pose.x + pose.vx * dt, pose.pose.y + pose.vy * dt,
                           geometry::normalizeAngle(pose.pose.phi + pose.omega * dt)};
  struct Placed {
    double distance;
    PacketObstacle obstacle;
  };
  std::vector<Placed> placed;
  for (const perception::ObstacleSighting& s : seen.obstacles) {
    if (!std::isfinite(s.x) || !std::isfinite(s.y) || !std::isfinite(s.width)) continue;
    const geometry::Vec2 nearest(s.x, s.y);
    const double range = nearest.norm();
    const double radius = std::clamp(0.5 * s.width, kMinObstacleRadius_m, kMaxObstacleRadius_m);
    // The centre lies behind the nearest point, along the ray from the robot.
    const geometry::Vec2 centre =
        range > 1e-6 ? geometry::Vec2(nearest * ((range + radius) / range)) : nearest;
    const geometry::Vec2 field = geometry::pointRobotToField(at, centre);
    if (!std::isfinite(field.x()) || !std::isfinite(field.y())) continue;
    PacketObstacle o;
    o.x = static_cast<float>(std::clamp(field.x(), -kMaxFieldCoordinate_m, kMaxFieldCoordinate_m));
    o.y = static_cast<float>(std::clamp(field.y(), -kMaxFieldCoordinate_m, kMaxFieldCoordinate_m));
    o.radius = static_cast<float>(radius);
    placed.push_back({range, o});
  }
  std::sort(placed.begin(), placed.end(),
            [](const Placed& a, const Placed& b) { return a.distance < b.distance; });
  for (std::size_t i = 0; i < placed.size() && i < static_cast<std::size_t>(kMaxObstacles); ++i)
    out.push_back(placed[i].obstacle);
  return out;
}

}  // namespace fieldline::teamcomm
