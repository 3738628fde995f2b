// Scripted trajectories and the tracking law.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "common/robot/trajectory.hpp"

namespace fieldline::robot {
namespace trajectory_test {

constexpr double kPi = std::numbers::pi;

TEST(Trajectory, FigureEightRunsAtConstantSpeedWithHeadingAlongThePath) {
  FigureEightSpec spec;
  spec.center = {1.0, -0.5};
  spec.length = 6.0;
  spec.width = 3.0;
  spec.speed = 0.8;
  const Trajectory traj(spec, {});
  const auto start = traj.at(0.0);
  EXPECT_NEAR(start.pose.x, 1.0, 1e-9);
  EXPECT_NEAR(start.pose.y, -0.5, 1e-9);
  const double dt = 1e-3;
  double max_x = -1e9;
  double max_y = -1e9;
  for (double t = 0.0; t < 40.0; t += 0.05) {
    const auto a = traj.at(t);
    const auto b = traj.at(t + dt);
    const geometry::Vec2 v = (b.pose.position() - a.pose.position()) / dt;
    EXPECT_NEAR(v.norm(), 0.8, 2e-3) << "t=" << t;
    EXPECT_NEAR(a.velocity.norm(), 0.8, 1e-9);
    EXPECT_NEAR(geometry::angleDiff(a.pose.phi, std::atan2(v.y(), v.x())), 0.0, 5e-3);
    EXPECT_NEAR(geometry::angleDiff(b.pose.phi, a.pose.phi) / dt, a.omega, 0.02);
    max_x = std::max(max_x, a.pose.x);
    max_y = std::max(max_y, a.pose.y);
  }
  EXPECT_NEAR(max_x, 1.0 + 3.0, 1e-3);
  EXPECT_NEAR(max_y, -0.5 + 1.5, 1e-3);
}

TEST(Trajectory, FigureEightIsPeriodic) {
  FigureEightSpec spec;
  spec.speed = 1.0;
  const Trajectory traj(spec, {});
  // Find the period: the first return to the centre with the start heading after a full lap.
  const auto s0 = traj.at(0.0);
  double best_t = 0.0;
  double best = 1e9;
  for (double t = 5.0; t < 40.0; t += 0.001) {
    const auto s = traj.at(t);
    const double d = (s.pose.position() - s0.pose.position()).norm() +
                     std::abs(geometry::angleDiff(s.pose.phi, s0.pose.phi));
    if (d < best) {
      best = d;
      best_t = t;
    }
  }
  EXPECT_LT(best, 2e-3);
  const auto later = traj.at(best_t + 3.3);
  const auto early = traj.at(3.3);
  EXPECT_NEAR(later.pose.x, early.pose.x, 3e-3);
  EXPECT_NEAR(later.pose.y, early.pose.y, 3e-3);
}

TEST(Trajectory, WaypointTourVisitsItsPointsAndLoops) {
  WaypointSpec spec;
  spec.points = {{1.0, 0.0}, {1.0, 2.0}};
  spec.speed = 0.5;
  spec.loop = true;
  const Trajectory traj(spec, {0.0, 0.0, 0.3});
  EXPECT_NEAR(traj.at(1.0).pose.x, 0.5, 1e-12);
  EXPECT_NEAR(traj.at(1.0).pose.phi, 0.0, 1e-12);
  EXPECT_NEAR(traj.at(4.0).pose.y, 1.0, 1e-12);
  EXPECT_NEAR(traj.at(4.0).pose.phi, kPi / 2.0, 1e-12);
  EXPECT_NEAR(traj.at(4.0).velocity.y(), 0.5, 1e-12);
  // Approach 2 s, then the loop 1 -> 2 -> 1 takes 8 s.
  EXPECT_NEAR(traj.at(3.0 + 8.0).pose.y, traj.at(3.0).pose.y, 1e-9);
  EXPECT_NEAR(traj.at(7.0).pose.y, 1.5, 1e-12);  // on the way back down

  spec.loop = false;
  spec.face_along_path = false;
  const Trajectory once(spec, {0.0, 0.0, 0.3});
  const auto end = once.at(100.0);
  EXPECT_NEAR(end.pose.x, 1.0, 1e-12);
  EXPECT_NEAR(end.pose.y, 2.0, 1e-12);
  EXPECT_NEAR(end.pose.phi, 0.3, 1e-12);
  EXPECT_EQ(end.velocity.norm(), 0.0);
}

TEST(Trajectory, RotateStandAndRandomPlay) {
  const Trajectory rotate(RotateSpec{0.5}, {1.0, 2.0, 0.0});
  EXPECT_NEAR(rotate.at(2.0).pose.phi, 1.0, 1e-12);
  EXPECT_NEAR(rotate.at(2.0).pose.x, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(rotate.at(2.0).omega, 0.5);
  const Trajectory stand(StandSpec{}, {1.0, 2.0, 3.0});
  EXPECT_DOUBLE_EQ(stand.at(50.0).pose.phi, 3.0);

  RandomPlaySpec r;
  r.half_length = 3.0;
  r.half_width = 2.0;
  r.seed = 99;
  const Trajectory a(r, {});
  const Trajectory b(r, {});
  r.seed = 100;
  const Trajectory c(r, {});
  bool differs = false;
  for (double t = 0.0; t < 120.0; t += 0.5) {
    const auto sa = a.at(t);
    EXPECT_DOUBLE_EQ(sa.pose.x, b.at(t).pose.x);
    EXPECT_LE(std::abs(sa.pose.x), 3.0 + 1e-9);
    EXPECT_LE(std::abs(sa.pose.y), 2.0 + 1e-9);
    differs = differs || std::abs(sa.pose.x - c.at(t).pose.x) > 1e-6;
  }
  EXPECT_TRUE(differs);
}

TEST(Follower, FeedForwardOnTheReferenceAndCorrectionOffIt) {
  RobotParams p;
  p.max_speed = 2.0;
  p.max_omega = 4.0;
  TrajectorySample ref;
  ref.pose = {1.0, 1.0, kPi / 2.0};
  ref.velocity = {0.0, 1.0};
  ref.omega = 0.4;
  // On the reference: the robot faces +y, so the field velocity +y is straight ahead.
  const auto on = followTrajectory(ref, ref.pose, p);
  EXPECT_NEAR(on.vx, 0.5, 1e-12);
  EXPECT_NEAR(on.vy, 0.0, 1e-12);
  EXPECT_NEAR(on.omega, 0.1, 1e-12);
  // 10 cm to the right of it (field +x of the robot means its right): steer left.
  const auto off = followTrajectory(ref, {1.1, 1.0, kPi / 2.0}, p);
  EXPECT_NEAR(off.vy, 2.0 * 0.1 / 2.0, 1e-12);
  // Far away: the translation is limited to full speed, direction kept.
  ref.velocity = {0.0, 3.0};
  const auto fast = followTrajectory(ref, ref.pose, p);
  EXPECT_NEAR(std::hypot(fast.vx, fast.vy), 1.0, 1e-12);
}

}  // namespace trajectory_test
}  // namespace fieldline::robot
