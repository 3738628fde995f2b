// The obstacles a robot sends its teammates: what its camera saw (VISION_OBSTACLES, robot frame,
// at the frame's exposure time) placed on the field with its own pose. Plain library.
#pragma once

#include <vector>

#include "common/perception/estimates.hpp"
#include "common/perception/obstacles.hpp"
#include "teamcomm/packet.hpp"

namespace fieldline::teamcomm {

// Each sighting's centre (its nearest floor point pushed back along the viewing ray by half its
// width; radius = half the width, 0.05..kMaxObstacleRadius_m) in the field frame, with `pose`
// moved to the frame's time by its velocities; nearest first, at most kMaxObstacles, clamped to
// the packet's ranges. Empty when the pose is not localized (neither tracking nor odometry only)
// or more than `max_gap_us` µs
// from the frame's time (a pose that old would put the obstacles in the wrong place), and
// without the non-finite sightings.
std::vector<PacketObstacle> obstaclesInField(const perception::ObstacleSightings& seen,
                                             const perception::RobotEstimate& pose,
                                             std::int64_t max_gap_us = 200'000);

}  // namespace fieldline::teamcomm
