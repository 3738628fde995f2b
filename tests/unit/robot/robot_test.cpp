// Robot parameters, omni kinematics (seed eq. 4.29-4.37), motor model (eq. 4.45) and wheel
// odometry (seed 4.8).
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "common/robot/motor_model.hpp"
#include "common/robot/omni_kinematics.hpp"
#include "common/robot/robot_params.hpp"
#include "common/robot/wheel_odometry.hpp"

namespace fieldline::robot {
namespace robot_test {

constexpr double kPi = std::numbers::pi;

RobotParams fu2004() {
  return loadRobotPreset("fu2004");
}

TEST(RobotParams, LoadsTheSeedRobot) {
  const auto p = fu2004();
  EXPECT_EQ(p.ticksPerWheelRevolution(), 768);
  EXPECT_DOUBLE_EQ(p.controller_latency, 0.008);
  EXPECT_DOUBLE_EQ(p.odometry_rate, 50.0);
  EXPECT_NEAR(p.max_speed, 3.5, 1e-12);
  // Seed geometry: side wheels at +-60 deg from the heading, the third straight behind.
  EXPECT_NEAR(p.wheels[0].angle, -kPi / 3.0, 1e-12);
  EXPECT_NEAR(p.wheels[1].angle, kPi / 3.0, 1e-12);
  EXPECT_NEAR(p.wheels[2].angle, kPi, 1e-12);
  const auto truth = p.trueWheels();
  EXPECT_NEAR(truth[0].radius, p.wheels[0].radius * (1.0 + p.simulation.wheel_radius_error[0]),
              1e-15);
}

TEST(RobotParams, RejectsUnknownKeysAndBadRanges) {
  const std::string base = R"(name: t
mass: 8
radius: 0.2
max_speed: 3.5
max_omega: 6
controller_latency: 0.008
odometry_rate: 50
watchdog_timeout: 0.2
wheels:
  - {angle: -1.0, distance: 0.2, radius: 0.04}
  - {angle: 1.0, distance: 0.2, radius: 0.04}
  - {angle: 3.1, distance: 0.2, radius: 0.04}
encoder: {pulses_per_motor_revolution: 64, gear_ratio: 12}
motor: {max_wheel_speed: 4, time_constant: 0.15}
simulation:
  wheel_radius_error: [0, 0, 0]
  wheel_angle_error: [0, 0, 0]
  slip_noise: 0
  rotation_noise: 0
  collision_rotation_noise: 0
)";
  EXPECT_NO_THROW(loadRobotParams(config::Node::loadString(base, "t.yaml")));
  EXPECT_THROW(loadRobotParams(config::Node::loadString(base + "colour: red\n", "t.yaml")),
               config::Error);
  std::string negative_mass = base;
  negative_mass.replace(negative_mass.find("mass: 8"), 7, "mass: -8");
  try {
    loadRobotParams(config::Node::loadString(negative_mass, "t.yaml"));
    FAIL() << "negative mass accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("t.yaml:2: mass"), std::string::npos) << e.what();
  }
}

TEST(OmniKinematics, HandComputedWheelSpeeds) {
  const OmniKinematics k(fu2004().wheels);
  // Forward at 1 m/s: the side wheels turn against each other at sin(60 deg), the back one rests.
  const Eigen::Vector3d forward = k.wheelSpeeds({1.0, 0.0, 0.0});
  EXPECT_NEAR(forward[0], std::sqrt(3.0) / 2.0, 1e-12);
  EXPECT_NEAR(forward[1], -std::sqrt(3.0) / 2.0, 1e-12);
  EXPECT_NEAR(forward[2], 0.0, 1e-12);
  // Left at 1 m/s: the back wheel drives with -1, the side wheels with cos(60 deg).
  const Eigen::Vector3d left = k.wheelSpeeds({0.0, 1.0, 0.0});
  EXPECT_NEAR(left[0], 0.5, 1e-12);
  EXPECT_NEAR(left[1], 0.5, 1e-12);
  EXPECT_NEAR(left[2], -1.0, 1e-12);
  // Turning at 1 rad/s: every contact point moves L = 0.19 m/s along its drive direction.
  const Eigen::Vector3d turn = k.wheelSpeeds({0.0, 0.0, 1.0});
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(turn[i], 0.19, 1e-12);
  // eq. 4.36: angular speed = ground speed / r_e.
  EXPECT_NEAR(k.wheelAngularSpeeds({0.0, 0.0, 1.0})[0], 0.19 / 0.04, 1e-12);
}

TEST(OmniKinematics, RoundTripOnTheSeedGeometryAndOnPerturbedOnes) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (const auto& wheels : {fu2004().wheels, fu2004().trueWheels()}) {
    const OmniKinematics k(wheels);
    EXPECT_TRUE((k.robotMatrix() * k.robotMatrixInverse()).isIdentity(1e-12));
    for (int trial = 0; trial < 200; ++trial) {
      const Twist t{u(rng), u(rng), u(rng)};
      const Twist back = k.twist(k.wheelSpeeds(t));
      EXPECT_NEAR(back.vx, t.vx, 1e-12);
      EXPECT_NEAR(back.vy, t.vy, 1e-12);
      EXPECT_NEAR(back.omega, t.omega, 1e-12);
      const Eigen::Vector3d speeds(u(rng), u(rng), u(rng));
      EXPECT_TRUE(k.wheelSpeeds(k.twist(speeds)).isApprox(speeds, 1e-12));
      const Twist from_angular = k.twistFromAngularSpeeds(k.wheelAngularSpeeds(t));
      EXPECT_NEAR(from_angular.omega, t.omega, 1e-12);
    }
  }
}

TEST(OmniKinematics, FieldMatrixMatchesTheRobotFrameMatrix) {
  const OmniKinematics k(fu2004().wheels);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (int trial = 0; trial < 50; ++trial) {
    const double phi = u(rng);
    const Eigen::Vector3d field_velocity(u(rng), u(rng), u(rng));
    // The same motion seen from the robot: rotate the translation by -phi.
    const geometry::Vec2 body = geometry::rotate(field_velocity.head<2>(), -phi);
    const Eigen::Vector3d expected = k.wheelSpeeds({body.x(), body.y(), field_velocity.z()});
    EXPECT_TRUE((k.fieldMatrix(phi) * field_velocity).isApprox(expected, 1e-12));
    EXPECT_TRUE((k.fieldMatrix(phi) * k.fieldMatrixInverse(phi)).isIdentity(1e-12));
  }
  // At phi = 0 the field and robot matrices coincide.
  EXPECT_TRUE(k.fieldMatrix(0.0).isApprox(k.robotMatrix(), 1e-15));
}

TEST(OmniKinematics, RejectsASingularLayout) {
  WheelSet parallel = fu2004().wheels;
  parallel[1].angle = parallel[0].angle;
  parallel[2].angle = parallel[0].angle + kPi;
  EXPECT_THROW(OmniKinematics{parallel}, std::invalid_argument);
}

TEST(ArcMovement, QuarterCircle) {
  // 1 m/s forward while turning at 1 rad/s for pi/2 s: a quarter of a 1 m circle to the left.
  const auto m = arcMovement({kPi / 2.0, 0.0, kPi / 2.0});
  EXPECT_NEAR(m.dx, 1.0, 1e-12);
  EXPECT_NEAR(m.dy, 1.0, 1e-12);
  EXPECT_NEAR(m.dphi, kPi / 2.0, 1e-15);
  const auto straight = arcMovement({0.3, -0.2, 0.0});
  EXPECT_DOUBLE_EQ(straight.dx, 0.3);
  EXPECT_DOUBLE_EQ(straight.dy, -0.2);
}

TEST(MotorModel, ParametersFromConfig) {
  const auto p = fu2004();
  const auto m = MotorModel::fromParams(p);
  EXPECT_NEAR(m.beta(), 8.0 / 0.15, 1e-12);
  EXPECT_NEAR(m.alpha(), 8.0 / 0.15 * 4.0, 1e-12);
  EXPECT_NEAR(m.timeConstant(), 0.15, 1e-12);
  EXPECT_NEAR(m.steadyStateSpeed(0.5), 2.0, 1e-12);
  // eq. 4.45 at rest and at the steady state.
  EXPECT_NEAR(m.force(1.0, 0.0), m.alpha(), 1e-12);
  EXPECT_NEAR(m.force(1.0, 4.0), 0.0, 1e-12);
}

TEST(MotorModel, StepResponseIsTheAnalyticFirstOrderResponse) {
  const MotorModel m(200.0, 50.0, 10.0);  // tau = 0.2 s, v_inf = 4 m/s at u = 1
  // One time constant: 1 - 1/e of the final speed; three: 95 %.
  EXPECT_NEAR(m.speedAfter(0.0, 1.0, 0.2), 4.0 * (1.0 - std::exp(-1.0)), 1e-12);
  EXPECT_NEAR(m.speedAfter(0.0, 1.0, 0.6), 4.0 * (1.0 - std::exp(-3.0)), 1e-12);
  // Integrating m dv/dt = f with small Euler steps converges to the same curve.
  double v = 0.0;
  const double dt = 1e-5;
  for (int i = 0; i < 30000; ++i)
    v += dt * m.force(1.0, v) / m.mass();
  EXPECT_NEAR(v, m.speedAfter(0.0, 1.0, 0.3), 1e-4);
  // Stepping in pieces equals one step: the exact solution does not depend on the step size.
  double pieces = 1.0;
  for (int i = 0; i < 7; ++i)
    pieces = m.speedAfter(pieces, -0.5, 0.05);
  EXPECT_NEAR(pieces, m.speedAfter(1.0, -0.5, 0.35), 1e-12);
  const WheelVector three =
      m.speedsAfter(Eigen::Vector3d(0.0, 1.0, -1.0), Eigen::Vector3d(1.0, 0.0, 0.5), 0.1);
  EXPECT_NEAR(three[1], m.speedAfter(1.0, 0.0, 0.1), 1e-12);
  EXPECT_NEAR(three[2], m.speedAfter(-1.0, 0.5, 0.1), 1e-12);
}

TEST(WheelCommands, ScalesAllWheelsTogetherWhenOneSaturates) {
  const auto p = fu2004();
  const OmniKinematics k(p.wheels);
  // Full forward: 3.5 m/s needs sin(60) * 3.5 = 3.03 m/s at the side wheels, under 4 m/s.
  const Eigen::Vector3d fwd = wheelCommands({1.0, 0.0, 0.0}, p, k);
  EXPECT_NEAR(fwd[0], std::sqrt(3.0) / 2.0 * 3.5 / 4.0, 1e-12);
  // Full diagonal plus rotation saturates; the largest wheel gets exactly 1, the ratio is kept.
  const Eigen::Vector3d diag = wheelCommands({1.0, 1.0, 1.0}, p, k);
  const Eigen::Vector3d raw = k.wheelSpeeds(desiredTwist({1.0, 1.0, 1.0}, p));
  EXPECT_NEAR(diag.cwiseAbs().maxCoeff(), 1.0, 1e-12);
  EXPECT_TRUE(diag.normalized().isApprox(raw.normalized(), 1e-12));
  // Out-of-range inputs are clamped, NaN gives a stop.
  EXPECT_TRUE(wheelCommands({5.0, 0.0, 0.0}, p, k).isApprox(fwd, 1e-12));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(wheelCommands({nan, 0.5, 0.0}, p, k).isZero());
}

TEST(WheelOdometry, TickDeltaSurvivesWrapAround) {
  EXPECT_EQ(tickDelta(5, 2), 3);
  EXPECT_EQ(tickDelta(-3, 4), -7);
  const std::int32_t top = std::numeric_limits<std::int32_t>::max();
  EXPECT_EQ(tickDelta(std::numeric_limits<std::int32_t>::min() + 4, top - 5), 10);
  EXPECT_EQ(tickDelta(top - 5, std::numeric_limits<std::int32_t>::min() + 4), -10);
}

TEST(WheelOdometry, OneMetreForwardFromTicks) {
  const auto p = fu2004();
  WheelOdometry odo(p);
  // 1 m forward turns the side wheels by -+sin(60) / r_e rad: 768 ticks per 2 pi.
  const double side = std::sqrt(3.0) / 2.0 / 0.04 / (2.0 * kPi) * 768.0;
  const auto t = static_cast<std::int32_t>(std::lround(side));
  const TickCounts start{1000, -2000, 7};
  EXPECT_FALSE(odo.update(start).has_value());
  const auto m = odo.update({start[0] + t, start[1] - t, start[2]});
  ASSERT_TRUE(m.has_value());
  // One tick is 2 pi r_e / 768 = 0.33 mm of wheel travel.
  const double tick_travel = 2.0 * kPi * 0.04 / 768.0;
  EXPECT_NEAR(m->dx, 1.0, 2.0 * tick_travel);
  EXPECT_NEAR(m->dy, 0.0, 1e-12);
  EXPECT_NEAR(m->dphi, 0.0, 1e-12);
  EXPECT_NEAR(odo.pose().x, m->dx, 1e-15);
  // Equal ticks on all wheels: a turn on the spot of 768 * r_e / L per revolution.
  odo.reset();
  odo.update({0, 0, 0});
  odo.update({768, 768, 768});
  EXPECT_NEAR(odo.pose().phi, geometry::normalizeAngle(2.0 * kPi * 0.04 / 0.19), 1e-12);
  EXPECT_NEAR(odo.pose().x, 0.0, 1e-12);
}

RobotParams fourWheel() {
  return loadRobotPreset("four_wheel");
}

TEST(RobotParams, LoadsAFourWheeledRobotAndRefusesOtherCounts) {
  const auto p = fourWheel();
  ASSERT_EQ(p.wheelCount(), 4);
  EXPECT_NEAR(p.wheels[0].angle, kPi / 4.0, 1e-12);
  EXPECT_NEAR(p.wheels[3].angle, -kPi / 4.0, 1e-12);
  EXPECT_EQ(p.simulation.wheel_angle_error.size(), 4u);
  EXPECT_EQ(p.trueWheels().size(), 4u);

  const std::string head = R"(name: t
mass: 8
radius: 0.2
max_speed: 3.5
max_omega: 6
controller_latency: 0.008
odometry_rate: 50
watchdog_timeout: 0.2
wheels:
)";
  const std::string tail = R"(encoder: {pulses_per_motor_revolution: 64, gear_ratio: 12}
motor: {max_wheel_speed: 4, time_constant: 0.15}
simulation:
  wheel_radius_error: [0, 0, 0, 0]
  wheel_angle_error: [0, 0, 0, 0]
  slip_noise: 0
  rotation_noise: 0
  collision_rotation_noise: 0
)";
  const std::string wheel = "  - {angle: A, distance: 0.2, radius: 0.04}\n";
  auto wheels = [&](std::initializer_list<const char*> angles) {
    std::string out;
    for (const char* a : angles) {
      std::string w = wheel;
      w.replace(w.find('A'), 1, a);
      out += w;
    }
    return out;
  };
  // Any angles: an uneven layout loads.
  EXPECT_EQ(loadRobotParams(config::Node::loadString(
                                head + wheels({"0.5", "2.0", "-2.5", "-1.2"}) + tail, "t.yaml"))
                .wheelCount(),
            4);
  // Five wheels, or two, are refused with the file's line.
  for (const auto& bad : {wheels({"0.5", "2.0", "-2.5", "-1.2", "3.0"}), wheels({"0.5", "2.0"})}) {
    try {
      loadRobotParams(config::Node::loadString(head + bad + tail, "t.yaml"));
      FAIL() << "wheel count accepted";
    } catch (const config::Error& e) {
      EXPECT_NE(std::string(e.what()).find("3 or 4 wheels"), std::string::npos) << e.what();
    }
  }
  // Four wheels that all drive along one axis (two pairs of parallel wheels on one line) cannot
  // turn the robot sideways: refused as singular.
  try {
    loadRobotParams(config::Node::loadString(
        head + wheels({"0.0", "3.141592653589793", "0.0", "3.141592653589793"}) + tail, "t.yaml"));
    FAIL() << "singular layout accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
  // Per-wheel simulation errors must have one value per wheel.
  std::string three_errors = tail;
  three_errors.replace(three_errors.find("[0, 0, 0, 0]"), 12, "[0, 0, 0]");
  EXPECT_THROW(loadRobotParams(config::Node::loadString(
                   head + wheels({"0.5", "2.0", "-2.5", "-1.2"}) + three_errors, "t.yaml")),
               config::Error);
}

TEST(OmniKinematics, FourWheelsOnTwoAxesAreSingularButTheShippedLayoutIsNot) {
  EXPECT_TRUE(wheelLayoutRegular(fourWheel().wheels));
  // Wheels that all roll along one axis (two pairs facing opposite ways) cannot drive sideways:
  // M has rank 2, and the layout must be refused.
  WheelSet one_axis = fourWheel().wheels;
  one_axis[1].angle = one_axis[0].angle;
  one_axis[2].angle = one_axis[0].angle + kPi;
  one_axis[3].angle = one_axis[0].angle + kPi;
  EXPECT_FALSE(wheelLayoutRegular(one_axis));
  EXPECT_THROW(OmniKinematics{one_axis}, std::invalid_argument);
}

TEST(OmniKinematics, FourWheelsHandComputedAndLeastSquares) {
  const OmniKinematics k(fourWheel().wheels);
  ASSERT_EQ(k.wheelCount(), 4);
  // Forward at 1 m/s: every wheel at 45 degrees to the heading drives at -+sin(45 deg).
  const WheelVector forward = k.wheelSpeeds({1.0, 0.0, 0.0});
  ASSERT_EQ(forward.size(), 4);
  const double s = std::sqrt(0.5);
  EXPECT_NEAR(forward[0], -s, 1e-12);
  EXPECT_NEAR(forward[1], -s, 1e-12);
  EXPECT_NEAR(forward[2], s, 1e-12);
  EXPECT_NEAR(forward[3], s, 1e-12);
  // The least-squares inverse is a left inverse: M^+ M = I (every twist comes back exactly).
  EXPECT_TRUE((k.robotMatrixInverse() * k.robotMatrix()).isIdentity(1e-12));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 100; ++trial) {
    const Twist t{u(rng), u(rng), u(rng)};
    const Twist back = k.twist(k.wheelSpeeds(t));
    EXPECT_NEAR(back.vx, t.vx, 1e-12);
    EXPECT_NEAR(back.vy, t.vy, 1e-12);
    EXPECT_NEAR(back.omega, t.omega, 1e-12);
    // Four speeds that no rigid motion explains: the twist is the one whose wheel speeds are
    // nearest (the residual is orthogonal to every column of M).
    WheelVector speeds(4);
    speeds << u(rng), u(rng), u(rng), u(rng);
    const WheelVector residual = speeds - k.wheelSpeeds(k.twist(speeds));
    EXPECT_LT((k.robotMatrix().transpose() * residual).norm(), 1e-12);
  }
  // One wheel slipping (0.1 m/s more than the others say) moves the estimate by a quarter of
  // its error or less, where three wheels would take all of it in.
  WheelVector slip = k.wheelSpeeds({1.0, 0.0, 0.0});
  slip[0] += 0.1;
  const Twist fit = k.twist(slip);
  EXPECT_LT(std::hypot(fit.vx - 1.0, fit.vy), 0.1 * s + 1e-12);
  // The field matrix and its inverse at a heading.
  EXPECT_TRUE((k.fieldMatrixInverse(0.7) * k.fieldMatrix(0.7)).isIdentity(1e-12));
}

TEST(WheelOdometry, FourWheelsOneMetreSidewaysAndWrongCounts) {
  const auto p = fourWheel();
  WheelOdometry odo(p);
  // 1 m left: wheel i turns by cos(a_i) / r_e rad.
  TickCounts start{5, -6, 7, -8};
  EXPECT_FALSE(odo.update(start).has_value());
  TickCounts next = start;
  for (std::size_t i = 0; i < 4; ++i)
    next[i] += static_cast<std::int32_t>(
        std::lround(std::cos(p.wheels[i].angle) / 0.04 / (2.0 * kPi) * 768.0));
  const auto m = odo.update(next);
  ASSERT_TRUE(m.has_value());
  const double tick_travel = 2.0 * kPi * 0.04 / 768.0;
  EXPECT_NEAR(m->dy, 1.0, 2.0 * tick_travel);
  EXPECT_NEAR(m->dx, 0.0, 2.0 * tick_travel);
  EXPECT_NEAR(m->dphi, 0.0, 1e-3);
  // Three counts for four wheels are refused.
  EXPECT_THROW(odo.update({1, 2, 3}), std::invalid_argument);
}

TEST(ArcMovement, IntegratedTwistInvertsTheArc) {
  for (const Eigen::Vector3d& v :
       {Eigen::Vector3d(0.3, -0.2, 0.0), Eigen::Vector3d(1.0, 0.5, 1.2),
        Eigen::Vector3d(-0.4, 0.1, -2.5), Eigen::Vector3d(0, 0, 1e-12)}) {
    EXPECT_TRUE(integratedTwist(arcMovement(v)).isApprox(v, 1e-12)) << v.transpose();
  }
}

}  // namespace robot_test
}  // namespace fieldline::robot
