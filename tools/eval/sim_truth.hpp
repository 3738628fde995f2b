#pragma once
// One SIM_WORLD message as an evaluation truth sample: used by fieldline-eval live and from a
// recording, and by the team-ball replay bench.
#include <cstddef>
#include <utility>
#include <vector>

#include <fieldline/world_state_t.hpp>

#include "tools/eval/evaluation.hpp"

namespace fieldline::eval {

// Appends the message's robots and ball when it is newer than the last sample (the simulator's
// bus may repeat or reorder a message).
inline void appendTruth(std::vector<TruthSample>& truth, const world_state_t& w) {
  TruthSample t;
  t.utime = w.header.utime;
  for (int i = 0; i < w.num_robots; ++i) {
    const auto k = static_cast<std::size_t>(i);
    t.robots[w.robot_id[k]] = {w.robot_x[k], w.robot_y[k], w.robot_phi[k], w.robot_kidnaps[k]};
  }
  t.ball_x = w.ball_x;
  t.ball_y = w.ball_y;
  if (truth.empty() || t.utime > truth.back().utime) truth.push_back(std::move(t));
}

}  // namespace fieldline::eval
