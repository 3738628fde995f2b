#include "services/world_sim/published_motion.hpp"

#include <algorithm>

namespace fieldline::world_sim {

const std::vector<PublishedMotion>& PublishedMotionTracker::next(
    const std::vector<RobotTruth>& robots, double time, double max_interval_s) {
  motion_.resize(robots.size());
  const double interval = time - previous_time_;
  const bool usable = has_previous_ && interval > 0.0 && interval <= max_interval_s;
  for (std::size_t i = 0; i < robots.size(); ++i) {
    const RobotTruth& r = robots[i];
    PublishedMotion& m = motion_[i];
    m = {r.velocity, r.omega};
    const auto it = std::find_if(previous_.begin(), previous_.end(),
                                 [&](const Previous& p) { return p.id == r.id; });
    if (usable && it != previous_.end() && it->kidnaps == r.kidnaps) {
      m.velocity = (r.pose.position() - it->pose.position()) / interval;
      m.omega = geometry::angleDiff(r.pose.phi, it->pose.phi) / interval;
    }
  }
  // Kept in place (no allocation once the team's size is known): SIM_WORLD goes out 100 times a
  // second.
  previous_.resize(robots.size());
  for (std::size_t i = 0; i < robots.size(); ++i)
    previous_[i] = {robots[i].id, robots[i].pose, robots[i].kidnaps};
  previous_time_ = time;
  has_previous_ = true;
  return motion_;
}

}  // namespace fieldline::world_sim
