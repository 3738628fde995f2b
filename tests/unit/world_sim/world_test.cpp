// The simulated world: odometry from its encoders matches its truth when slip is off, drifts
// with the default slip, collisions and kidnaps fool odometry, the ball rolls and bounces, and a
// run is deterministic for a seed.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <Eigen/LU>

#include "common/robot/wheel_odometry.hpp"
#include "services/world_sim/world.hpp"
#include "services/world_sim/world_snapshot.hpp"

namespace fieldline::world_sim {
namespace world_test {

using scenario::loadScenarioPreset;
using scenario::RobotSpec;
using scenario::Scenario;

constexpr double kPi = std::numbers::pi;

Scenario oneRobot(const geometry::Pose2& start, double slip_scale) {
  Scenario s;
  s.name = "test";
  s.seed = 3;
  s.physics_rate = 400.0;
  s.slip_scale = slip_scale;
  RobotSpec r;
  r.id = 1;
  r.start = start;
  s.robots.push_back(r);
  s.ball.start = {-9.0, -6.0};
  return s;
}

// Runs `world` for `seconds`, steering every robot along its scenario trajectory from the truth
// at 50 Hz (as the pilot does), feeding each robot's ticks to its odometry.
void drive(World& world, double seconds, std::vector<robot::WheelOdometry>* odometry = nullptr) {
  std::vector<robot::Trajectory> paths;
  for (const auto& spec : world.scenario().robots)
    paths.emplace_back(spec.trajectory, spec.start);
  const auto steps_per_sample = static_cast<int>(std::lround(world.scenario().physics_rate / 50.0));
  const double end = world.time() + seconds;
  while (world.time() < end - 1e-9) {
    for (std::size_t i = 0; i < paths.size(); ++i) {
      const auto ref = paths[i].at(world.time());
      world.setCommand(i,
                       robot::followTrajectory(ref, world.robots()[i].pose, world.robotParams()));
    }
    for (int k = 0; k < steps_per_sample; ++k)
      world.step();
    if (odometry) {
      for (std::size_t i = 0; i < odometry->size(); ++i)
        (*odometry)[i].update(world.ticks(i));
    }
  }
}

TEST(World, TicksToWheelRotationsToMotionMatchTheTruthWithinATickWithoutSlip) {
  const geometry::Pose2 start{1.0, -2.0, 0.3};
  World world(oneRobot(start, 0.0));
  const auto& params = world.robotParams();
  robot::WheelOdometry odo(params);
  odo.reset(start);
  odo.update(world.ticks(0));
  const robot::TickCounts first = world.ticks(0);
  // A step command from rest: all wheels follow the same first-order curve, so the twist keeps
  // its direction and the true path is one arc, which odometry reconstructs exactly.
  world.setCommand(0, {0.3, 0.2, 0.25});
  double turned = 0.0;                            // unwrapped true rotation
  for (int sample = 0; sample < 150; ++sample) {  // 3 s at 50 Hz
    for (int k = 0; k < 8; ++k) {
      world.step();
      turned += world.robots()[0].omega * world.stepSize();
    }
    odo.update(world.ticks(0));
  }
  const auto& truth = world.robots()[0];
  const double rad_per_tick = 2.0 * kPi / params.ticksPerWheelRevolution();
  const double tick_travel = rad_per_tick * params.wheels[0].radius;  // 0.33 mm
  const robot::TickCounts last = world.ticks(0);
  robot::TickDeltas delta(3, 0);
  for (int i = 0; i < 3; ++i) {
    // Each counter is the wheel's rotation, floored to whole ticks.
    EXPECT_LT(std::abs(last[i] * rad_per_tick - truth.wheel_angles[i]), rad_per_tick);
    delta[i] = robot::tickDelta(last[i], first[i]);
  }
  EXPECT_GT(std::abs(delta[0]), 1000);  // it really drove
  // The true path is one arc: recover its integrated twist (sx, sy, theta) from the true
  // movement, map it to wheel rotations with the kinematics and compare with the ticks.
  const auto truth_moved = geometry::movementBetween(start, truth.pose);
  const double theta = turned;
  const double s = std::sin(theta) / theta;
  const double c = (1.0 - std::cos(theta)) / theta;
  Eigen::Matrix2d arc;
  arc << s, -c, c, s;
  const Eigen::Vector2d integrated =
      arc.inverse() * Eigen::Vector2d(truth_moved.dx, truth_moved.dy);
  const Eigen::Vector3d true_rotation =
      odo.kinematics().wheelAngularSpeeds({integrated.x(), integrated.y(), theta});
  const Eigen::Vector3d tick_rotation = odo.wheelRotations(delta);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(tick_rotation[i], true_rotation[i], rad_per_tick);
  // In the field that is a few tenths of a millimetre per tick, times the lever of a heading error.
  const auto moved = odo.movement(delta);
  EXPECT_NEAR(moved.dphi, theta, 3.0 * tick_travel / (3.0 * params.wheels[0].distance));
  EXPECT_NEAR(moved.dx, truth_moved.dx, 3e-3);
  EXPECT_NEAR(moved.dy, truth_moved.dy, 3e-3);
  // Integrated sample by sample at 50 Hz the rounding of each sample adds up a little.
  EXPECT_NEAR(odo.pose().x, truth.pose.x, 5.0 * tick_travel);
  EXPECT_NEAR(odo.pose().y, truth.pose.y, 5.0 * tick_travel);
  EXPECT_NEAR(geometry::angleDiff(odo.pose().phi, truth.pose.phi), 0.0, 0.002);
}

TEST(World, WithoutSlipOdometryFollowsAFigureEight) {
  Scenario s = oneRobot({}, 0.0);
  s.robots[0].trajectory = robot::FigureEightSpec{{0.0, 0.0}, 6.0, 3.0, 0.0, 0.8};
  s.robots[0].start = robot::Trajectory(s.robots[0].trajectory, {}).startPose();
  World world(s);
  std::vector<robot::WheelOdometry> odo{robot::WheelOdometry(world.robotParams())};
  odo[0].reset(s.robots[0].start);
  odo[0].update(world.ticks(0));
  drive(world, 30.0, &odo);
  // The twist changes within each 20 ms sample here, so the arcs are approximations: still
  // millimetres after 24 m of driving.
  const auto& truth = world.robots()[0].pose;
  EXPECT_LT((odo[0].pose().position() - truth.position()).norm(), 0.01);
  EXPECT_LT(std::abs(geometry::angleDiff(odo[0].pose().phi, truth.phi)), 0.005);
  // And the follower kept the robot on its path.
  const auto ref = robot::Trajectory(s.robots[0].trajectory, {}).at(world.time());
  EXPECT_LT((ref.pose.position() - truth.position()).norm(), 0.1);
}

TEST(World, FourWheelsWithoutSlipOdometryFollowsAFigureEight) {
  Scenario s = oneRobot({}, 0.0);
  s.robot = "four_wheel";
  s.robots[0].trajectory = robot::FigureEightSpec{{0.0, 0.0}, 6.0, 3.0, 0.0, 0.8};
  s.robots[0].start = robot::Trajectory(s.robots[0].trajectory, {}).startPose();
  World world(s);
  ASSERT_EQ(world.robotParams().wheelCount(), 4);
  ASSERT_EQ(world.ticks(0).size(), 4u);
  std::vector<robot::WheelOdometry> odo{robot::WheelOdometry(world.robotParams())};
  odo[0].reset(s.robots[0].start);
  odo[0].update(world.ticks(0));
  drive(world, 30.0, &odo);
  const auto& truth = world.robots()[0].pose;
  EXPECT_LT((odo[0].pose().position() - truth.position()).norm(), 0.01);
  EXPECT_LT(std::abs(geometry::angleDiff(odo[0].pose().phi, truth.phi)), 0.005);
  const auto ref = robot::Trajectory(s.robots[0].trajectory, {}).at(world.time());
  EXPECT_LT((ref.pose.position() - truth.position()).norm(), 0.1);
  // Without errors the four wheels agree: only the millimetres of the slip's chord-for-arc
  // bookkeeping over 24 m (as with three wheels).
  EXPECT_LT(world.robots()[0].wheel_slip.cwiseAbs().maxCoeff(), 0.005);
}

TEST(World, FourWheelsWithTheirErrorsFightAndDrift) {
  World world(loadScenarioPreset("four_wheel_figure_eight"));
  ASSERT_EQ(world.robotParams().wheelCount(), 4);
  std::vector<robot::WheelOdometry> odo{robot::WheelOdometry(world.robotParams())};
  odo[0].reset(world.scenario().robots[0].start);
  odo[0].update(world.ticks(0));
  drive(world, 30.0, &odo);
  const auto& truth = world.robots()[0].pose;
  const double position_error = (odo[0].pose().position() - truth.position()).norm();
  EXPECT_GT(position_error, 0.02);
  EXPECT_LT(position_error, 5.0);
  // The wheels' true radii and angles differ, and the body follows their best fit: each wheel
  // slips by what the fit does not explain.
  EXPECT_GT(world.robots()[0].wheel_slip.cwiseAbs().maxCoeff(), 0.01);
  // A snapshot of a four-wheeled world continues it bit for bit.
  const WorldSnapshot snap = decodeSnapshot(encodeSnapshot(world.snapshot()));
  ASSERT_EQ(snap.robots[0].wheel_angles.size(), 4);
  World copy(loadScenarioPreset("four_wheel_figure_eight"));
  copy.restore(snap);
  for (int k = 0; k < 100; ++k) {
    world.setCommand(0, {0.2, 0.1, 0.3});
    copy.setCommand(0, {0.2, 0.1, 0.3});
    world.step();
    copy.step();
  }
  EXPECT_EQ(world.robots()[0].pose.x, copy.robots()[0].pose.x);
  EXPECT_EQ(world.ticks(0), copy.ticks(0));
  // A snapshot of a three-wheeled world does not fit it.
  World three(loadScenarioPreset("figure_eight"));
  WorldSnapshot other = three.snapshot();
  other.scenario = "four_wheel_figure_eight";
  EXPECT_THROW(copy.restore(other), std::invalid_argument);
}

TEST(World, DefaultSlipMakesOdometryDrift) {
  World world(loadScenarioPreset("figure_eight"));
  std::vector<robot::WheelOdometry> odo{robot::WheelOdometry(world.robotParams())};
  odo[0].reset(world.scenario().robots[0].start);
  odo[0].update(world.ticks(0));
  drive(world, 60.0, &odo);
  const auto& truth = world.robots()[0].pose;
  const double position_error = (odo[0].pose().position() - truth.position()).norm();
  const double heading_error = std::abs(geometry::angleDiff(odo[0].pose().phi, truth.phi));
  // Clearly nonzero, as on a real robot, but not absurd.
  EXPECT_GT(position_error, 0.05);
  EXPECT_LT(position_error, 5.0);
  EXPECT_GT(heading_error, 0.01);
}

TEST(World, MotorResponseInTheWorld) {
  World world(oneRobot({0.0, 0.0, kPi / 2.0}, 0.0));
  world.setCommand(0, {0.5, 0.0, 0.0});
  world.runUntil(0.15);  // one time constant
  const auto& r = world.robots()[0];
  const double expected = 0.5 * 3.5 * (1.0 - std::exp(-1.0));
  // Facing +y, forward is the field's +y.
  EXPECT_NEAR(r.velocity.y(), expected, 0.01);
  EXPECT_NEAR(r.velocity.x(), 0.0, 1e-9);
  world.runUntil(2.0);
  EXPECT_NEAR(world.robots()[0].velocity.y(), 1.75, 1e-3);
}

TEST(World, TheBarrierStopsTheBodyButNotTheWheels) {
  Scenario s = oneRobot({10.5, 0.0, 0.0}, 0.0);
  World world(s);
  const double barrier = world.field().carpetHalfExtent().x();
  robot::WheelOdometry odo(world.robotParams());
  odo.reset(s.robots[0].start);
  odo.update(world.ticks(0));
  world.setCommand(0, {0.5, 0.0, 0.0});
  world.runUntil(3.0);
  odo.update(world.ticks(0));
  const auto& r = world.robots()[0];
  EXPECT_LE(r.pose.x, barrier - world.robotParams().radius + 1e-9);
  EXPECT_GT(r.contact_steps, 0);
  EXPECT_TRUE(r.in_contact);
  // Odometry believes the robot drove on through the barrier.
  EXPECT_GT(odo.pose().x, barrier + 1.0);
}

TEST(World, WheelsSlipAgainstTheBarrierNotInFreeDriving) {
  // Without slip noise a free robot's wheels roll exactly (the slip is the arc-versus-chord
  // rounding of a step); driving into the barrier, the two front wheels slip at their speed.
  Scenario s = oneRobot({9.0, 0.0, 0.0}, 0.0);
  World world(s);
  world.setCommand(0, {0.5, 0.0, 0.0});
  world.runUntil(0.4);
  const Eigen::Vector3d free = world.robots()[0].wheel_slip;
  EXPECT_LT(free.cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_FALSE(world.robots()[0].in_contact);
  world.runUntil(3.0);
  ASSERT_TRUE(world.robots()[0].in_contact);
  const Eigen::Vector3d before = world.robots()[0].wheel_slip;
  world.runUntil(4.0);
  const Eigen::Vector3d in_one_second = world.robots()[0].wheel_slip - before;
  // The body stands still: each wheel's slip speed is its surface speed (1.75 m/s forward at
  // wheels 0 and 1, at -+60 degrees: |cos 30 deg| * 1.75 = 1.52 m/s; the back wheel rolls
  // across).
  EXPECT_NEAR(std::abs(in_one_second[0]), 1.75 * std::cos(kPi / 6.0), 0.05);
  EXPECT_NEAR(std::abs(in_one_second[1]), 1.75 * std::cos(kPi / 6.0), 0.05);
  EXPECT_LT(std::abs(in_one_second[2]), 0.05);
}

TEST(World, KidnapMovesTheRobotWithoutTurningAWheel) {
  Scenario s = oneRobot({0.0, 0.0, 0.0}, 1.0);
  s.kidnaps.push_back({1.0, 1, {3.0, -2.0, 1.0}});
  World world(s);
  world.runUntil(0.99);
  const auto before = world.ticks(0);
  world.runUntil(1.5);
  EXPECT_EQ(world.ticks(0), before);
  EXPECT_NEAR(world.robots()[0].pose.x, 3.0, 1e-12);
  EXPECT_NEAR(world.robots()[0].pose.phi, 1.0, 1e-12);
  EXPECT_EQ(world.robots()[0].kidnaps, 1);
}

TEST(World, BallRollsWithFrictionAndBouncesOffTheBarrier) {
  Scenario s = oneRobot({-8.0, -5.0, 0.0}, 0.0);
  s.ball.start = {0.0, 0.0};
  s.ball.kicks.push_back({0.0, std::nullopt, {2.0, 0.0}});
  World world(s);
  world.runUntil(1.0);
  // v = v0 - a t, x = v0 t - a t^2 / 2 with a = 0.4 m/s^2.
  EXPECT_NEAR(world.ball().velocity.x(), 1.6, 1e-9);
  EXPECT_NEAR(world.ball().position.x(), 1.8, 0.01);
  world.runUntil(20.0);
  EXPECT_EQ(world.ball().velocity.norm(), 0.0);  // it stopped

  Scenario b = oneRobot({-8.0, -5.0, 0.0}, 0.0);
  const double wall = World(b).field().carpetHalfExtent().y();
  b.ball.start = {0.0, wall - 1.0};
  b.ball.kicks.push_back({0.0, std::nullopt, {0.0, 5.0}});
  World bounce(b);
  bounce.runUntil(0.5);
  EXPECT_LT(bounce.ball().velocity.y(), 0.0);
  // It hits the barrier after t1 with 5 - 0.4 t1, keeps 60 % and slows down again.
  const double gap = 1.0 - bounce.ball().radius;
  const double t1 = (5.0 - std::sqrt(25.0 - 4.0 * 0.2 * gap)) / (2.0 * 0.2);
  const double after = 0.6 * (5.0 - 0.4 * t1) - 0.4 * (0.5 - t1);
  EXPECT_NEAR(bounce.ball().velocity.y(), -after, 0.01);
  EXPECT_LE(bounce.ball().position.y(), wall - bounce.ball().radius);
}

TEST(World, ARobotPushesTheBall) {
  Scenario s = oneRobot({0.0, 0.0, 0.0}, 0.0);
  s.ball.start = {0.6, 0.0};
  World world(s);
  world.setCommand(0, {0.5, 0.0, 0.0});
  world.runUntil(1.0);
  EXPECT_GT(world.ball().velocity.x(), 0.5);
  EXPECT_GT(world.ball().position.x(), world.robots()[0].pose.x + 0.3);
}

TEST(World, DeterministicForASeed) {
  Scenario s = loadScenarioPreset("default");
  World a(s);
  World b(s);
  drive(a, 12.0);
  drive(b, 12.0);
  s.seed += 1;
  World c(s);
  drive(c, 12.0);
  bool differs = false;
  for (std::size_t i = 0; i < a.robots().size(); ++i) {
    EXPECT_EQ(a.robots()[i].pose.x, b.robots()[i].pose.x);
    EXPECT_EQ(a.robots()[i].pose.phi, b.robots()[i].pose.phi);
    EXPECT_EQ(a.ticks(i), b.ticks(i));
    differs = differs || a.robots()[i].pose.x != c.robots()[i].pose.x;
  }
  EXPECT_EQ(a.ball().position, b.ball().position);
  EXPECT_EQ(a.opponents()[2].pose.x, b.opponents()[2].pose.x);
  EXPECT_TRUE(differs);
}

}  // namespace world_test
}  // namespace fieldline::world_sim
