// The ball filter with late poses: a sighting is kept in the robot frame for `settle_s` and
// fused again on every estimate with the pose the robot has for its time *then*. The pose at a
// frame's time improves after the frame arrived: that frame's own line points are matched after
// its ball was seen (they travel in a separate message), and the next line frame tells how far
// odometry had drifted meanwhile (`smoothedPose`). Frames older than `settle_s` are committed
// into a filter that is never re-run. Plain library: no bus, no clock.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>

#include "common/perception/estimates.hpp"
#include "common/time/clock.hpp"
#include "services/fusion/ball_filter.hpp"
#include "services/fusion/ekf.hpp"

namespace fieldline::fusion {

// The robot's best state at a time (empty: none known for that time).
using PoseAt = std::function<std::optional<EkfState>(Utime)>;

// The state at `t` from `filtered`, with the correction the next line frame after `t` made
// (`corrections`: the utimes of line frames, ascending) spread back linearly over the interval
// from the frame at or before `t`: what a smoother does when odometry drifts at a steady rate
// between two frames. Without a later frame, or without a frame before `t` within `max_gap_s`
// of the later one, the filtered state. The covariance is the filtered one (conservative).
std::optional<EkfState> smoothedPose(const PoseAt& filtered, const std::deque<Utime>& corrections,
                                     Utime t, double max_gap_s = 0.5);

class BallTracker {
 public:
  explicit BallTracker(BallFilterParams params = {});

  // A camera frame's ball sighting (visible or not). Refused at once and counted by the caller:
  // a visible sighting with NaN/inf or non-positive sigmas (kNotFinite), a frame older than the
  // newest committed one (kOutOfOrder). Otherwise kept until it is committed.
  BallRejection add(const perception::BallSighting& s);
  // Commits the frames at least `settle_s` older than `now` with the poses `pose_at` gives now,
  // fuses the newer ones on a copy of the committed filter, and returns the estimate at `now`.
  perception::BallEstimate estimate(Utime now, const PoseAt& pose_at);

  // Refusals of committed frames by kind ("ball_outlier", "ball_too_far", "ball_no_pose", ...).
  const std::map<std::string, std::uint64_t>& refusals() const { return refusals_; }
  // The filter of the committed frames (its restart and invalidation counters).
  const BallFilter& committed() const { return committed_; }
  // The robot's pose was moved to its twin: the committed estimate follows (the pending frames
  // are in the robot frame and take the new poses anyway).
  void mirrorThroughCentre() { committed_.mirrorThroughCentre(); }
  std::size_t pending() const { return pending_.size(); }

 private:
  // Fuses one frame into `f` with the pose at its time; counts refusals when `count`.
  void apply(BallFilter& f, const perception::BallSighting& s, const PoseAt& pose_at, bool count);

  BallFilterParams params_;
  BallFilter committed_;
  // Frames not yet committed, ascending utime.
  std::deque<perception::BallSighting> pending_;
  // utime of the newest committed frame.
  std::optional<Utime> committed_until_;
  std::map<std::string, std::uint64_t> refusals_;
};

}  // namespace fieldline::fusion
