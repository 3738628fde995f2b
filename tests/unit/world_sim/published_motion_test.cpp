// SIM_WORLD's robot velocities (published_motion.hpp): a camera carries the newest state to its
// exposure, up to a publish interval later, with them. A physics step's own velocity carries
// the step's white slip noise; the mean since the previous published state does not multiply it.
#include "services/world_sim/published_motion.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace fieldline::world_sim {
namespace published_motion_test {

scenario::Scenario turningRobot() {
  scenario::Scenario s;
  s.name = "test";
  s.seed = 5;
  s.physics_rate = 400.0;
  s.slip_scale = 1.0;  // the default slip, as in every scenario
  scenario::RobotSpec r;
  r.id = 1;
  r.start = {0.0, 0.0, 0.0};
  s.robots.push_back(r);
  s.ball.start = {-9.0, -6.0};
  return s;
}

struct CarryErrors {
  double step_rms = 0.0;       // carried with the step's own omega
  double published_rms = 0.0;  // carried with PublishedMotionTracker's
};

// Publishes at 100 Hz while the robot drives and turns; carries each published heading 2.5, 5,
// 7.5 and 10 ms on (where a camera frame falls) and compares it with the world's heading then.
CarryErrors carryErrors(const robot::NormalizedCommand& command) {
  World world(turningRobot());
  world.setCommand(0, command);
  for (int k = 0; k < 400; ++k)
    world.step();  // up to speed
  PublishedMotionTracker tracker;
  CarryErrors e;
  int n = 0;
  for (int publish = 0; publish < 400; ++publish) {
    const RobotTruth state = world.robots()[0];
    const PublishedMotion m = tracker.next(world.robots(), world.time(), 0.025)[0];
    for (int k = 1; k <= 4; ++k) {
      world.step();
      if (publish < 2) continue;  // the tracker's first call has no interval yet
      const double dt = k * world.stepSeconds();
      const double truth = world.robots()[0].pose.phi;
      const double by_step = geometry::angleDiff(state.pose.phi + state.omega * dt, truth);
      const double by_mean = geometry::angleDiff(state.pose.phi + m.omega * dt, truth);
      e.step_rms += by_step * by_step;
      e.published_rms += by_mean * by_mean;
      ++n;
    }
  }
  e.step_rms = std::sqrt(e.step_rms / n);
  e.published_rms = std::sqrt(e.published_rms / n);
  return e;
}

TEST(PublishedMotion, ACarriedStateMissesTheHeadingLessThanWithTheStepsOwnTurnRate) {
  // Drives at about 1 m/s and turns at about 1.5 rad/s.
  const CarryErrors e = carryErrors({0.4, 0.2, 0.3});
  // The step's own turn rate: its noise times up to four steps (0.012 rad rms here, three times
  // the ball detector's 0.004 rad bearing sigma); with the interval's mean 0.008, of which 0.006
  // is the heading's own random walk over the carried time, which nothing published can know.
  EXPECT_GT(e.step_rms, 0.009) << e.published_rms;
  EXPECT_LT(e.published_rms, 0.75 * e.step_rms) << e.step_rms;
}

TEST(PublishedMotion, TheStepsOwnMotionWithoutAnIntervalOrAfterAKidnap) {
  World world(turningRobot());
  world.setCommand(0, {0.4, 0.2, 0.3});
  for (int k = 0; k < 40; ++k)
    world.step();
  PublishedMotionTracker tracker;
  std::vector<PublishedMotion> m = tracker.next(world.robots(), world.time(), 0.025);
  EXPECT_EQ(m[0].omega, world.robots()[0].omega);  // first call
  const geometry::Pose2 before = world.robots()[0].pose;
  const double t0 = world.time();
  for (int k = 0; k < 4; ++k)
    world.step();
  m = tracker.next(world.robots(), world.time(), 0.025);
  EXPECT_DOUBLE_EQ(m[0].omega, geometry::angleDiff(world.robots()[0].pose.phi, before.phi) /
                                   (world.time() - t0));
  EXPECT_DOUBLE_EQ(m[0].velocity.x(), (world.robots()[0].pose.x - before.x) / (world.time() - t0));
  // Too long since the previous call: the step's own.
  for (int k = 0; k < 20; ++k)
    world.step();
  m = tracker.next(world.robots(), world.time(), 0.025);
  EXPECT_EQ(m[0].omega, world.robots()[0].omega);
  // Kidnapped since: the step's own.
  std::vector<RobotTruth> robots = world.robots();
  for (int k = 0; k < 4; ++k)
    world.step();
  robots = world.robots();
  robots[0].kidnaps += 1;
  m = tracker.next(robots, world.time(), 0.025);
  EXPECT_EQ(m[0].omega, robots[0].omega);
}

}  // namespace published_motion_test
}  // namespace fieldline::world_sim
