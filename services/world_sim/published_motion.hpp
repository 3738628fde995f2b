// The motion SIM_WORLD publishes with each robot's state, for whoever carries the state to a
// later time (the simulated camera renders each frame at its exposure, up to a publish interval
// after the newest state): the mean velocity over the interval since the robot's previous
// published state. A physics step's own velocity (RobotTruth::velocity, omega) carries that
// step's white slip noise divided by the step: in a live match at 400 Hz its heading rate was
// 1.2-2.8 rad/s rms off the mean over the next 10 ms, and a camera carrying a state 0-10 ms on
// with it turned its frames by 0.010-0.016 rad rms (more at fast turns), 2.5-4 times the ball
// detector's bearing sigma (docs/log/2026-12-07-session12-ball.md).
#pragma once

#include <vector>

#include "common/geometry/geometry.hpp"
#include "services/world_sim/world.hpp"

namespace fieldline::world_sim {

struct PublishedMotion {
  // Field frame, m/s, and rad/s.
  geometry::Vec2 velocity = geometry::Vec2::Zero();
  double omega = 0.0;
};

class PublishedMotionTracker {
 public:
  // The motion to publish with `robots` at world time `time` (s), one per robot in order: the
  // mean since each robot's state at the previous call, or the step's own for a robot without
  // one, kidnapped since, or when the previous call is not in (0, max_interval_s] before `time`.
  // Remembers the robots' poses for the next call.
  // The result stays valid until the next call.
  const std::vector<PublishedMotion>& next(const std::vector<RobotTruth>& robots, double time,
                                           double max_interval_s);

 private:
  struct Previous {
    int id = 0;
    geometry::Pose2 pose;
    int kidnaps = 0;
  };
  std::vector<Previous> previous_;
  std::vector<PublishedMotion> motion_;
  double previous_time_ = 0.0;
  bool has_previous_ = false;
};

}  // namespace fieldline::world_sim
