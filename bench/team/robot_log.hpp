// fieldline-team-ball-replay: a robot's recorded estimates as they arrived.
#pragma once

#include <algorithm>
#include <iterator>
#include <vector>

#include "common/perception/estimates.hpp"
#include "common/time/clock.hpp"

namespace fieldline::team_bench {

struct Timed {
  Utime received = 0;  // log time of arrival
  perception::RobotEstimate robot;
  perception::BallEstimate ball;
};

struct RobotLog {
  std::vector<Timed> robots;  // ROBOT_STATE in arrival order
  std::vector<Timed> balls;   // BALL_STATE in arrival order
  std::vector<Utime> seen;    // stamps of the VISION_BALLs that saw a ball (truth clock)
};

// The newest entry received at or before `t` (nullptr: none).
inline const Timed* newestAt(const std::vector<Timed>& v, Utime t) {
  const auto it = std::upper_bound(v.begin(), v.end(), t,
                                   [](Utime x, const Timed& e) { return x < e.received; });
  return it == v.begin() ? nullptr : &*std::prev(it);
}

}  // namespace fieldline::team_bench
