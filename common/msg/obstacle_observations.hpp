// obstacle_observations_t (VISION_OBSTACLES) <-> perception::ObstacleSightings.
// header.utime <-> utime.
#pragma once

#include <fieldline/obstacle_observations_t.hpp>

#include "common/perception/obstacles.hpp"

namespace fieldline::msg {

// The obstacles of a validated message (bus/validate.hpp has checked that the arrays have
// `count` finite elements).
void fromMessage(const obstacle_observations_t& m, perception::ObstacleSightings& out);
perception::ObstacleSightings toObstacleSightings(const obstacle_observations_t& m);

// Writes header.utime, count and the arrays (the rest of the header is the node's).
void toMessage(const perception::ObstacleSightings& s, obstacle_observations_t& m);

}  // namespace fieldline::msg
