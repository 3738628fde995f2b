#include "services/world_sim/published_motion.hpp"

namespace fieldline::world_sim {

std::vector<PublishedMotion> PublishedMotionTracker::next(const std::vector<RobotTruth>& robots,
                                                          double time, double max_interval_s) {
  std::vector<PublishedMotion> out;
  out.reserve(robots.size());
  const double interval = time - previous_time_;
  const bool usable = has_previous_ && interval > 0.0 && interval <= max_interval_s;
  for (const RobotTruth& r : robots) {
    PublishedMotion m{r.velocity, r.omega};
    const auto it = previous_.find(r.id);
    if (usable && it != previous_.end() && it->second.kidnaps == r.kidnaps) {
      const geometry::Pose2& before = it->second.pose;
      m.velocity = (r.pose.position() - before.position()) / interval;
      m.omega = geometry::angleDiff(r.pose.phi, before.phi) / interval;
    }
    out.push_back(m);
  }
  previous_.clear();
  for (const RobotTruth& r : robots)
    previous_[r.id] = {r.pose, r.kidnaps};
  previous_time_ = time;
  has_previous_ = true;
  return out;
}

}  // namespace fieldline::world_sim
