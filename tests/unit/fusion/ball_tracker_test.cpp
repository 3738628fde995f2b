// The ball tracker: a sighting is fused again with the newest pose for its time until it
// settles, late frames within the window are put in order, bad frames are refused at once, and
// the smoothed pose spreads the next line frame's correction back over the interval.
#include "services/fusion/ball_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <gtest/gtest.h>

#include "common/geometry/geometry.hpp"
#include "tests/unit/fusion/bare_params.hpp"

namespace fieldline::fusion {
namespace ball_tracker_test {

constexpr Utime kStart = 1'800'000'000'000'000;
constexpr Utime kFrame = 33'333;

EkfState robotAt(const geometry::Pose2& pose, Utime t) {
  EkfState s;
  s.utime = t;
  s.x << pose.x, pose.y, pose.phi, 0, 0, 0, 0;
  s.p = StateMatrix::Identity() * 1e-4;
  return s;
}

// A still ball at `ball` seen from a still robot at `robot`, exactly.
perception::BallSighting sightingOf(const geometry::Vec2& ball, const geometry::Pose2& robot,
                                    Utime t) {
  const geometry::Vec2 local = geometry::pointFieldToRobot(robot, ball);
  perception::BallSighting s;
  s.utime = t;
  s.visible = true;
  s.x = local.x();
  s.y = local.y();
  s.sigma_radial = 0.05;
  s.sigma_tangential = 0.03;
  return s;
}

TEST(BallTracker, ASightingIsFusedAgainWithTheNewerPoseUntilItSettles) {
  BallFilterParams params = test::bareBall();
  params.settle_s = 0.3;
  BallTracker tracker(params);
  const geometry::Pose2 truth{0.0, 0.0, 0.0};
  const geometry::Vec2 ball(3.0, 0.0);
  // The robot first believes it is turned by 0.05 rad (3 m: 15 cm off), then a line frame
  // corrects the pose at the sighting's time.
  geometry::Pose2 believed{0.0, 0.0, 0.05};
  const PoseAt pose_at = [&](Utime t) { return std::optional<EkfState>(robotAt(believed, t)); };
  const Utime t = kStart;
  ASSERT_EQ(tracker.add(sightingOf(ball, truth, t)), BallRejection::kNone);
  const auto first = tracker.estimate(t + kFrame, pose_at);
  ASSERT_TRUE(first.valid);
  EXPECT_GT(std::hypot(first.x - ball.x(), first.y - ball.y()), 0.14);
  believed = truth;
  const auto second = tracker.estimate(t + 2 * kFrame, pose_at);
  EXPECT_LT(std::hypot(second.x - ball.x(), second.y - ball.y()), 1e-6);
  EXPECT_EQ(tracker.pending(), 1u);
  // Settled: committed with the pose of that moment; later changes of the pose do not reach it.
  const auto settled = tracker.estimate(t + 400'000, pose_at);
  EXPECT_EQ(tracker.pending(), 0u);
  believed = geometry::Pose2{0.0, 0.0, -0.2};
  const auto after = tracker.estimate(t + 433'333, pose_at);
  EXPECT_DOUBLE_EQ(after.x, settled.x);
  EXPECT_DOUBLE_EQ(after.y, settled.y);
}

TEST(BallTracker, WithoutSettlingEachFrameIsFusedOnceAsTheFilterWould) {
  BallTracker tracker(test::bareBall());  // settle_s 0
  BallFilter filter(test::bareBall());
  const geometry::Pose2 robot{1.0, -2.0, 2.0};
  const PoseAt pose_at = [&](Utime t) { return std::optional<EkfState>(robotAt(robot, t)); };
  for (int k = 0; k < 20; ++k) {
    const Utime t = kStart + k * kFrame;
    const geometry::Vec2 ball(2.0 + 0.05 * k, 0.5 - 0.02 * k);
    const auto s = sightingOf(ball, robot, t);
    ASSERT_EQ(tracker.add(s), BallRejection::kNone);
    filter.update(s, robotAt(robot, t));
    const auto a = tracker.estimate(t + 10'000, pose_at);
    const auto b = filter.estimate(t + 10'000);
    EXPECT_NEAR(a.x, b.x, 1e-12);
    EXPECT_NEAR(a.y, b.y, 1e-12);
    EXPECT_NEAR(a.vx, b.vx, 1e-12);
    EXPECT_EQ(tracker.pending(), 0u);
  }
}

TEST(BallTracker, LateFramesWithinTheWindowGiveTheInOrderResult) {
  BallFilterParams params = test::bareBall();
  params.settle_s = 0.5;
  BallTracker in_order(params);
  BallTracker shuffled(params);
  const geometry::Pose2 robot{-1.0, 1.0, 0.7};
  const PoseAt pose_at = [&](Utime t) { return std::optional<EkfState>(robotAt(robot, t)); };
  std::vector<perception::BallSighting> frames;
  for (int k = 0; k < 9; ++k) {
    frames.push_back(sightingOf({1.0 + 0.06 * k, 2.0 - 0.03 * k}, robot, kStart + k * kFrame));
  }
  frames[4].visible = false;  // a frame without the ball
  for (const auto& f : frames)
    ASSERT_EQ(in_order.add(f), BallRejection::kNone);
  for (int k : {2, 0, 1, 5, 3, 8, 4, 7, 6})
    ASSERT_EQ(shuffled.add(frames[static_cast<std::size_t>(k)]), BallRejection::kNone);
  const Utime now = kStart + 10 * kFrame;
  const auto a = in_order.estimate(now, pose_at);
  const auto b = shuffled.estimate(now, pose_at);
  EXPECT_DOUBLE_EQ(a.x, b.x);
  EXPECT_DOUBLE_EQ(a.y, b.y);
  EXPECT_DOUBLE_EQ(a.vx, b.vx);
  EXPECT_DOUBLE_EQ(a.vy, b.vy);
}

TEST(BallTracker, RefusesBadFramesAtOnceAndCountsCommittedRefusals) {
  BallTracker tracker(test::bareBall());
  perception::BallSighting nan = sightingOf({1.0, 1.0}, {}, kStart);
  nan.x = std::nan("");
  EXPECT_EQ(tracker.add(nan), BallRejection::kNotFinite);
  perception::BallSighting flat = sightingOf({1.0, 1.0}, {}, kStart);
  flat.sigma_tangential = 0.0;
  EXPECT_EQ(tracker.add(flat), BallRejection::kNotFinite);
  EXPECT_EQ(tracker.pending(), 0u);

  const PoseAt none = [](Utime) { return std::optional<EkfState>(); };
  const PoseAt still = [](Utime t) { return std::optional<EkfState>(robotAt({}, t)); };
  ASSERT_EQ(tracker.add(sightingOf({1.0, 1.0}, {}, kStart + kFrame)), BallRejection::kNone);
  // No pose for its time: counted, nothing fused.
  EXPECT_FALSE(tracker.estimate(kStart + 2 * kFrame, none).valid);
  EXPECT_EQ(tracker.refusals().at("ball_no_pose"), 1u);
  // Older than the newest committed frame: refused.
  EXPECT_EQ(tracker.add(sightingOf({1.0, 1.0}, {}, kStart)), BallRejection::kOutOfOrder);
  ASSERT_EQ(tracker.add(sightingOf({1.0, 1.0}, {}, kStart + 2 * kFrame)), BallRejection::kNone);
  ASSERT_EQ(tracker.add(sightingOf({30.0, 1.0}, {}, kStart + 3 * kFrame)), BallRejection::kNone);
  EXPECT_TRUE(tracker.estimate(kStart + 3 * kFrame, still).valid);
  EXPECT_EQ(tracker.refusals().at("ball_too_far"), 1u);
}

// Frames whose pose was not confirmed by a line correction lately are counted when they are
// committed, the visible and the unseen ones apart, and change nothing.
TEST(BallTracker, CountsFramesWithAnUnconfirmedPose) {
  BallFilterParams params = test::bareBall();
  params.pose_max_unconfirmed_s = 0.05;
  params.invalid_after_outlier = true;
  params.unseen_range_m = 6.0;
  params.unseen_frames = 1;
  BallTracker tracker(params);
  // Corrected at every frame up to kStart + 2 frames, then no more.
  const PoseAt pose = [](Utime t) {
    EkfState s = robotAt({}, t);
    s.last_correction_utime = std::min(t, kStart + 2 * kFrame);
    return std::optional<EkfState>(s);
  };
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(tracker.add(sightingOf({1.0, 1.0}, {}, kStart + k * kFrame)), BallRejection::kNone);
  }
  // Hidden, then far away, 0.1 and 0.13 s after the last correction.
  perception::BallSighting hidden;
  hidden.utime = kStart + 5 * kFrame;
  ASSERT_EQ(tracker.add(hidden), BallRejection::kNone);
  ASSERT_EQ(tracker.add(sightingOf({-2.0, 1.0}, {}, kStart + 6 * kFrame)), BallRejection::kNone);
  const auto e = tracker.estimate(kStart + 6 * kFrame, pose);  // settle_s 0: all committed
  EXPECT_FALSE(e.valid);  // withheld by the far sighting, not moved to it
  EXPECT_NEAR(e.x, 1.0, 1e-6);
  EXPECT_NEAR(e.y, 1.0, 1e-6);
  EXPECT_EQ(tracker.refusals().at("ball_pose_unconfirmed"), 1u);
  EXPECT_EQ(tracker.refusals().at("ball_missed_pose_unconfirmed"), 1u);
}

// A robot twisted by 0.8 rad between two line frames (10 Hz): the frames before confirmed its
// pose, the next one turns it back. Its three sightings in between land 2.3 m away; they are
// refused (no restart there) because the next correction turned the heading, and the estimate
// is withheld instead of moved. Without that check they restart the ball at the wrong place.
TEST(BallTracker, ASightingIsConfirmedOnlyWhenTheNextCorrectionHardlyTurns) {
  const geometry::Vec2 ball(3.0, 0.0);
  const Utime twist_end = kStart + 9 * kFrame;
  const PoseAt pose = [&](Utime t) {
    EkfState s = robotAt({0.0, 0.0, t >= twist_end ? 0.8 : 0.0}, t);
    s.last_correction_utime = kStart + (t - kStart) / (3 * kFrame) * (3 * kFrame);
    return std::optional<EkfState>(s);
  };
  auto run = [&](double max_turn_rad) {
    BallFilterParams params = test::bareBall();
    params.pose_max_unconfirmed_s = 0.15;
    params.pose_max_correction_rad = max_turn_rad;
    params.invalid_after_outlier = true;
    BallTracker tracker(params);
    for (int k = 0; k < 9; ++k) {
      const bool twisted = k >= 6;  // truly turned by 0.8 rad, estimated still at 0
      EXPECT_EQ(tracker.add(sightingOf(ball, {0.0, 0.0, twisted ? 0.8 : 0.0}, kStart + k * kFrame)),
                BallRejection::kNone);
    }
    const auto e = tracker.estimate(kStart + 8 * kFrame, pose);
    return std::make_pair(e, tracker.refusals());
  };
  const auto [on, on_refused] = run(0.1);
  EXPECT_FALSE(on.valid);
  EXPECT_NEAR(on.x, ball.x(), 1e-6);
  EXPECT_NEAR(on.y, ball.y(), 1e-6);
  EXPECT_EQ(on_refused.at("ball_pose_unconfirmed"), 3u);
  const auto [off, off_refused] = run(4.0);
  EXPECT_TRUE(off.valid);
  EXPECT_GT(std::hypot(off.x - ball.x(), off.y - ball.y()), 2.0);
  EXPECT_EQ(off_refused.count("ball_pose_unconfirmed"), 0u);
}

TEST(BallTracker, TheSmoothedPoseSpreadsTheNextCorrectionBack) {
  // Odometry says the robot turns at 0.2 rad/s from 0; the frame at t2 corrects the heading by
  // -0.02 rad and the position by (0.01, -0.03).
  const Utime t1 = kStart;
  const Utime t2 = kStart + 100'000;
  const PoseAt filtered = [&](Utime t) {
    const double dt = static_cast<double>(t - t1) * 1e-6;
    geometry::Pose2 p{0.5 * dt, 0.0, 0.2 * dt};
    if (t >= t2) {
      p.x += 0.01;
      p.y -= 0.03;
      p.phi -= 0.02;
    }
    return std::optional<EkfState>(robotAt(p, t));
  };
  const std::deque<Utime> frames{t1, t2};
  const auto mid = smoothedPose(filtered, frames, t1 + 25'000);
  ASSERT_TRUE(mid);
  // (The correction is read against the state 1 us before t2: its motion is within 1e-6.)
  EXPECT_NEAR(mid->x[2], 0.2 * 0.025 - 0.25 * 0.02, 1e-6);
  EXPECT_NEAR(mid->x[0], 0.5 * 0.025 + 0.25 * 0.01, 1e-6);
  EXPECT_NEAR(mid->x[1], -0.25 * 0.03, 1e-6);
  // At a frame's own time, and after the newest frame: the filtered state.
  EXPECT_NEAR(smoothedPose(filtered, frames, t1)->x[2], 0.0, 1e-12);
  EXPECT_NEAR(smoothedPose(filtered, frames, t2 + 10'000)->x[2], filtered(t2 + 10'000)->x[2],
              1e-12);
  // Frames too far apart are not bridged.
  const std::deque<Utime> sparse{t1, t1 + 900'000};
  EXPECT_NEAR(smoothedPose(filtered, sparse, t1 + 25'000)->x[2], 0.2 * 0.025, 1e-12);
}

}  // namespace ball_tracker_test
}  // namespace fieldline::fusion
