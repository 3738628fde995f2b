// fieldline-team-ball-replay --sightings: every visible VISION_BALL against the truth, in the
// robot frame, with what can explain its error: the robot's turn rate, the ball's bearing rate
// (a stamp error shows as error proportional to it), how near a body in front of the ball comes
// to hiding it, and fusion's heading error at the stamp (the ball goes to the field through it).
#pragma once

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <fieldline/world_state_t.hpp>

#include "common/perception/estimates.hpp"
#include "common/time/clock.hpp"
#include "tools/eval/evaluation.hpp"

namespace fieldline::team_bench {

class SightingRows {
 public:
  // Writes the header to `path` (empty: no output, every call does nothing).
  explicit SightingRows(const std::string& path);
  ~SightingRows() { close(); }
  SightingRows(const SightingRows&) = delete;
  SightingRows& operator=(const SightingRows&) = delete;

  bool open() const { return file_ != nullptr; }
  void close();
  // The bodies that can hide a ball (teammates and opponents) in a SIM_WORLD.
  void addWorld(const world_state_t& w);
  // One row for a visible sighting of robot `id` (stamp on the truth's clock); `pose_near`:
  // the robot's ROBOT_STATE nearest the stamp (on the truth's clock), or null.
  void write(const std::vector<eval::TruthSample>& truth, int id, const perception::BallSighting& b,
             const perception::RobotEstimate* pose_near);
  // The angular gap (rad) between the silhouette of the body in front of the ball nearest its
  // line of sight from robot `id` and the ball's, negative when they overlap (the ball partly
  // hidden); +inf without a body in front (or without output: no bodies are kept then).
  double occlusionGap(Utime t, int id, const eval::TruthRobot& robot, double bx, double by) const;

 private:
  struct Body {
    int id;  // robot id, or 0 for an opponent
    double x, y, radius;
  };
  std::FILE* file_ = nullptr;
  std::map<Utime, std::vector<Body>> bodies_;  // by SIM_WORLD utime
};

}  // namespace fieldline::team_bench
