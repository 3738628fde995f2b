// The simulator's ground truth (SIM_WORLD without LCM): true poses of the team's robots, the
// opponents and the ball. Read by the pilot (steering by truth), the simulated camera and the
// evaluation. Conversions in common/msg/world_state.hpp.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/geometry/geometry.hpp"

namespace fieldline::perception {

struct TrueRobot {
  // Robot number 1..6.
  int id = 0;
  // Field frame.
  geometry::Pose2 pose;
  // Field frame [m/s] and rotation [rad/s, CCW].
  geometry::Vec2 velocity = geometry::Vec2::Zero();
  double omega = 0.0;
  // Times it was lifted and put down elsewhere so far.
  int kidnaps = 0;
};

struct TrueOpponent {
  geometry::Pose2 pose;
  // Footprint radius [m].
  double radius = 0.0;
};

struct TrueBall {
  // Field frame [m, m/s].
  geometry::Vec2 position = geometry::Vec2::Zero();
  geometry::Vec2 velocity = geometry::Vec2::Zero();
  double radius = 0.0;
};

struct WorldTruth {
  // Simulated physical time of this state, µs since the epoch (the simulator's true time).
  std::int64_t utime = 0;
  std::string field;
  std::string scenario;
  // Footprint radius of the team's robots [m].
  double robot_radius = 0.0;
  std::vector<TrueRobot> robots;
  std::vector<TrueOpponent> opponents;
  TrueBall ball;

  // The robot with number `id`, or nullptr.
  const TrueRobot* robot(int id) const {
    for (const auto& r : robots)
      if (r.id == id) return &r;
    return nullptr;
  }
};

}  // namespace fieldline::perception
