#include "services/fusion/ball_tracker.hpp"

#include <algorithm>
#include <cmath>

#include "common/geometry/geometry.hpp"

namespace fieldline::fusion {

std::optional<EkfState> smoothedPose(const PoseAt& filtered, const std::deque<Utime>& corrections,
                                     Utime t, double max_gap_s) {
  std::optional<EkfState> s = filtered(t);
  if (!s) return s;
  const auto next = std::upper_bound(corrections.begin(), corrections.end(), t);
  if (next == corrections.end() || next == corrections.begin()) return s;
  const Utime t2 = *next;
  const Utime t1 = *std::prev(next);
  if (static_cast<double>(t2 - t1) * 1e-6 > max_gap_s) return s;
  // The correction at t2: the state there after the frame against the state just before it.
  const std::optional<EkfState> after = filtered(t2);
  const std::optional<EkfState> before = filtered(t2 - 1);
  if (!after || !before) return s;
  const double w = static_cast<double>(t - t1) / static_cast<double>(t2 - t1);
  s->x[0] += w * (after->x[0] - before->x[0]);
  s->x[1] += w * (after->x[1] - before->x[1]);
  s->x[2] = geometry::normalizeAngle(s->x[2] + w * geometry::angleDiff(after->x[2], before->x[2]));
  return s;
}

BallTracker::BallTracker(BallFilterParams params) : params_(params), committed_(params) {}

BallRejection BallTracker::add(const perception::BallSighting& s) {
  if (s.visible &&
      (!std::isfinite(s.x) || !std::isfinite(s.y) || !std::isfinite(s.sigma_radial) ||
       !std::isfinite(s.sigma_tangential) || s.sigma_radial <= 0.0 || s.sigma_tangential <= 0.0)) {
    return BallRejection::kNotFinite;
  }
  if (committed_until_ && s.utime < *committed_until_) return BallRejection::kOutOfOrder;
  const auto at =
      std::upper_bound(pending_.begin(), pending_.end(), s.utime,
                       [](Utime t, const perception::BallSighting& p) { return t < p.utime; });
  pending_.insert(at, s);
  return BallRejection::kNone;
}

void BallTracker::apply(BallFilter& f, const perception::BallSighting& s, const PoseAt& pose_at,
                        bool count) {
  const std::optional<EkfState> robot = pose_at(s.utime);
  if (!s.visible) {
    if (robot) f.missed(s.utime, *robot);
    return;
  }
  if (!robot) {
    if (count) ++refusals_["ball_no_pose"];
    return;
  }
  const BallRejection r = f.update(s, *robot);
  if (count && r != BallRejection::kNone) ++refusals_[toString(r)];
}

perception::BallEstimate BallTracker::estimate(Utime now, const PoseAt& pose_at) {
  const Utime settled = now - static_cast<Utime>(std::llround(params_.settle_s * 1e6));
  while (!pending_.empty() && pending_.front().utime <= settled) {
    apply(committed_, pending_.front(), pose_at, true);
    committed_until_ = pending_.front().utime;
    pending_.pop_front();
  }
  BallFilter work = committed_;
  for (const perception::BallSighting& s : pending_) {
    if (s.utime > now) break;
    apply(work, s, pose_at, false);
  }
  return work.estimate(now);
}

}  // namespace fieldline::fusion
