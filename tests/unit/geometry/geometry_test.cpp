#include "common/geometry/geometry.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

namespace fieldline::geometry {
namespace geometry_test {

constexpr double kPi = std::numbers::pi;
constexpr double kTol = 1e-12;

double deg(double d) {
  return d * kPi / 180.0;
}

void expectNear(const Vec2& actual, const Vec2& expected, double tol = kTol) {
  EXPECT_NEAR(actual.x(), expected.x(), tol);
  EXPECT_NEAR(actual.y(), expected.y(), tol);
}

void expectPoseNear(const Pose2& actual, const Pose2& expected, double tol = 1e-9) {
  EXPECT_NEAR(actual.x, expected.x, tol);
  EXPECT_NEAR(actual.y, expected.y, tol);
  EXPECT_NEAR(angleDiff(actual.phi, expected.phi), 0.0, tol);
}

// Seeded random poses spread over a large field and all headings.
class RandomPoses {
 public:
  explicit RandomPoses(unsigned seed) : rng_(seed) {}
  Pose2 pose() { return {pos_(rng_), pos_(rng_), angle_(rng_)}; }
  Vec2 point() { return Vec2(pos_(rng_), pos_(rng_)); }
  Movement movement() { return {pos_(rng_), pos_(rng_), 4.0 * angle_(rng_)}; }

 private:
  std::mt19937 rng_;
  std::uniform_real_distribution<double> pos_{-12.0, 12.0};
  std::uniform_real_distribution<double> angle_{-kPi, kPi};
};

TEST(NormalizeAngle, RangeIsHalfOpenMinusPiToPi) {
  EXPECT_DOUBLE_EQ(normalizeAngle(kPi), kPi);
  EXPECT_DOUBLE_EQ(normalizeAngle(-kPi), kPi);
  EXPECT_DOUBLE_EQ(normalizeAngle(3.0 * kPi), kPi);
  EXPECT_DOUBLE_EQ(normalizeAngle(-3.0 * kPi), kPi);
  EXPECT_DOUBLE_EQ(normalizeAngle(0.0), 0.0);
  EXPECT_NEAR(normalizeAngle(2.0 * kPi), 0.0, kTol);
  EXPECT_NEAR(normalizeAngle(deg(270)), deg(-90), kTol);
  EXPECT_NEAR(normalizeAngle(deg(-270)), deg(90), kTol);
  EXPECT_NEAR(normalizeAngle(deg(725)), deg(5), 1e-12);
  EXPECT_NEAR(normalizeAngle(-kPi + 1e-9), -kPi + 1e-9, kTol);
  EXPECT_NEAR(normalizeAngle(1000.0 * kPi + 0.5), 0.5, 1e-9);
}

TEST(NormalizeAngle, RandomValuesLandInRangeAndKeepTheDirection) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> any(-100.0, 100.0);
  for (int k = 0; k < 10000; ++k) {
    const double a = any(rng);
    const double n = normalizeAngle(a);
    ASSERT_GT(n, -kPi);
    ASSERT_LE(n, kPi);
    ASSERT_NEAR(std::cos(n), std::cos(a), 1e-9);
    ASSERT_NEAR(std::sin(n), std::sin(a), 1e-9);
  }
}

TEST(NormalizeAngle, NonFiniteStaysNonFinite) {
  EXPECT_TRUE(std::isnan(normalizeAngle(std::numeric_limits<double>::quiet_NaN())));
  EXPECT_FALSE(std::isfinite(normalizeAngle(std::numeric_limits<double>::infinity())));
}

TEST(AngleDiff, ShortestSignedTurn) {
  EXPECT_NEAR(angleDiff(deg(10), deg(350)), deg(20), kTol);
  EXPECT_NEAR(angleDiff(deg(350), deg(10)), deg(-20), kTol);
  EXPECT_NEAR(angleDiff(deg(-170), deg(170)), deg(20), kTol);
  EXPECT_NEAR(angleDiff(deg(90), deg(-90)), kPi, kTol);
  EXPECT_NEAR(angleDiff(1.0, 1.0), 0.0, kTol);
}

TEST(Rotate, QuarterTurns) {
  expectNear(rotate(Vec2(1, 0), kPi / 2), Vec2(0, 1));
  expectNear(rotate(Vec2(0, 1), kPi / 2), Vec2(-1, 0));
  expectNear(rotate(Vec2(2, 3), kPi), Vec2(-2, -3));
  expectNear(rotate(Vec2(1, 1), deg(45)), Vec2(0, std::sqrt(2.0)));
}

// Robot at (1, 2) facing +y: forward is field +y, left is field -x.
TEST(PointTransform, HandComputedRobotFacingPlusY) {
  const Pose2 robot{1.0, 2.0, deg(90)};
  expectNear(pointRobotToField(robot, Vec2(1, 0)), Vec2(1, 3));
  expectNear(pointRobotToField(robot, Vec2(0, 1)), Vec2(0, 2));
  expectNear(pointRobotToField(robot, Vec2(2, -1)), Vec2(2, 4));
  expectNear(pointFieldToRobot(robot, Vec2(1, 3)), Vec2(1, 0));
  expectNear(pointFieldToRobot(robot, Vec2(0, 0)), Vec2(-2, 1));
}

TEST(PointTransform, HandComputedDiagonalHeading) {
  // Facing 45 degrees from the origin: 1 m ahead is (s, s), 1 m left is (-s, s).
  const double s = std::sqrt(0.5);
  const Pose2 robot{0.0, 0.0, deg(45)};
  expectNear(pointRobotToField(robot, Vec2(1, 0)), Vec2(s, s));
  expectNear(pointRobotToField(robot, Vec2(0, 1)), Vec2(-s, s));
  // Facing -x from (3, -1): 2 m ahead is (1, -1), 1 m left is (3, -2).
  const Pose2 back{3.0, -1.0, kPi};
  expectNear(pointRobotToField(back, Vec2(2, 0)), Vec2(1, -1));
  expectNear(pointRobotToField(back, Vec2(0, 1)), Vec2(3, -2));
}

TEST(VectorTransform, IgnoresTheRobotPosition) {
  const Pose2 robot{5.0, -7.0, deg(90)};
  expectNear(vectorRobotToField(robot, Vec2(1, 0)), Vec2(0, 1));
  expectNear(vectorRobotToField(robot, Vec2(0, 2)), Vec2(-2, 0));
  expectNear(vectorFieldToRobot(robot, Vec2(0, 1)), Vec2(1, 0));
}

TEST(Transforms, RandomRoundTrips) {
  RandomPoses random(42);
  for (int k = 0; k < 2000; ++k) {
    const Pose2 robot = random.pose();
    const Vec2 p = random.point();
    expectNear(pointFieldToRobot(robot, pointRobotToField(robot, p)), p, 1e-9);
    expectNear(pointRobotToField(robot, pointFieldToRobot(robot, p)), p, 1e-9);
    expectNear(vectorFieldToRobot(robot, vectorRobotToField(robot, p)), p, 1e-9);
    // Distances are preserved by a rigid transform.
    const Vec2 q = random.point();
    ASSERT_NEAR((pointRobotToField(robot, p) - pointRobotToField(robot, q)).norm(), (p - q).norm(),
                1e-9);
    const Pose2 local = random.pose();
    expectPoseNear(poseFieldToRobot(robot, poseRobotToField(robot, local)), local);
    const Movement m = random.movement();
    const Movement back = movementFieldToRobot(robot, movementRobotToField(robot, m));
    ASSERT_NEAR(back.dx, m.dx, 1e-9);
    ASSERT_NEAR(back.dy, m.dy, 1e-9);
    ASSERT_EQ(back.dphi, m.dphi);
  }
}

TEST(PoseTransform, HandComputed) {
  const Pose2 robot{1.0, 2.0, deg(90)};
  // A feature 1 m ahead, facing the robot's left, is at (1, 3) facing -x.
  expectPoseNear(poseRobotToField(robot, Pose2{1.0, 0.0, deg(90)}), Pose2{1.0, 3.0, kPi});
  expectPoseNear(poseFieldToRobot(robot, Pose2{1.0, 3.0, kPi}), Pose2{1.0, 0.0, deg(90)});
  // Result angles are normalised.
  const Pose2 turned = poseRobotToField(Pose2{0, 0, deg(170)}, Pose2{0, 0, deg(20)});
  EXPECT_NEAR(turned.phi, deg(-170), kTol);
}

TEST(PoseComposition, InverseAndAssociativity) {
  RandomPoses random(3);
  for (int k = 0; k < 1000; ++k) {
    const Pose2 a = random.pose();
    const Pose2 b = random.pose();
    const Pose2 c = random.pose();
    expectPoseNear(compose(a, inverse(a)), Pose2{});
    expectPoseNear(compose(inverse(a), a), Pose2{});
    expectPoseNear(compose(compose(a, b), c), compose(a, compose(b, c)));
    expectPoseNear(inverse(inverse(a)), a);
    // A pose in frame a, expressed in the field, then back.
    expectPoseNear(compose(inverse(a), compose(a, b)), b);
  }
}

TEST(PoseComposition, HandComputedInverse) {
  // Robot at (1, 2) facing +y: the field origin is 2 m behind it and 1 m to its left, and the
  // field's x axis points to the robot's right (-90 degrees).
  expectPoseNear(inverse(Pose2{1.0, 2.0, deg(90)}), Pose2{-2.0, 1.0, deg(-90)});
}

TEST(Movement, ApplyHandComputed) {
  // Facing +y, moving 1 m forward and 0.5 m left while turning a quarter to the left.
  const Pose2 end = applyMovement(Pose2{1.0, 2.0, deg(90)}, Movement{1.0, 0.5, deg(90)});
  expectPoseNear(end, Pose2{0.5, 3.0, kPi});
  // Whole turns leave the heading unchanged and stay normalised.
  const Pose2 spun = applyMovement(Pose2{0, 0, 0.3}, Movement{0, 0, 4.0 * kPi});
  EXPECT_NEAR(spun.phi, 0.3, 1e-12);
}

TEST(Movement, BetweenHandComputed) {
  const Movement m = movementBetween(Pose2{1.0, 2.0, deg(90)}, Pose2{0.5, 3.0, kPi});
  EXPECT_NEAR(m.dx, 1.0, kTol);
  EXPECT_NEAR(m.dy, 0.5, kTol);
  EXPECT_NEAR(m.dphi, deg(90), kTol);
  // Across the +-pi seam the turn is the short one.
  const Movement seam = movementBetween(Pose2{0, 0, deg(170)}, Pose2{0, 0, deg(-170)});
  EXPECT_NEAR(seam.dphi, deg(20), kTol);
}

TEST(Movement, BetweenAndApplyAreInverse) {
  RandomPoses random(11);
  for (int k = 0; k < 2000; ++k) {
    const Pose2 a = random.pose();
    const Pose2 b = random.pose();
    expectPoseNear(applyMovement(a, movementBetween(a, b)), b);
    // A movement with |dphi| <= pi is recovered exactly.
    Movement m = random.movement();
    m.dphi = normalizeAngle(m.dphi);
    const Movement back = movementBetween(a, applyMovement(a, m));
    ASSERT_NEAR(back.dx, m.dx, 1e-9);
    ASSERT_NEAR(back.dy, m.dy, 1e-9);
    ASSERT_NEAR(back.dphi, m.dphi, 1e-9);
  }
}

TEST(Movement, ConcatenationEqualsApplyingInTurn) {
  RandomPoses random(5);
  for (int k = 0; k < 2000; ++k) {
    const Pose2 start = random.pose();
    const Movement first = random.movement();
    const Movement second = random.movement();
    const Movement both = concatenate(first, second);
    expectPoseNear(applyMovement(start, both), applyMovement(applyMovement(start, first), second));
    ASSERT_DOUBLE_EQ(both.dphi, first.dphi + second.dphi);
  }
}

TEST(Movement, ConcatenateHandComputed) {
  // 1 m forward, turn left a quarter, then 1 m forward: ends 1 m ahead and 1 m left.
  const Movement both = concatenate(Movement{1.0, 0.0, deg(90)}, Movement{1.0, 0.0, 0.0});
  EXPECT_NEAR(both.dx, 1.0, kTol);
  EXPECT_NEAR(both.dy, 1.0, kTol);
  EXPECT_NEAR(both.dphi, deg(90), kTol);
}

TEST(Movement, FieldFrameHandComputedAndConsistent) {
  // Facing +y, 1 m forward is +1 m along field y.
  const Pose2 robot{1.0, 2.0, deg(90)};
  const Movement in_field = movementRobotToField(robot, Movement{1.0, 0.0, 0.25});
  EXPECT_NEAR(in_field.dx, 0.0, kTol);
  EXPECT_NEAR(in_field.dy, 1.0, kTol);
  EXPECT_EQ(in_field.dphi, 0.25);
  // The field-frame translation is the difference of the field poses (seed: m = p_B - p_A).
  RandomPoses random(9);
  for (int k = 0; k < 1000; ++k) {
    const Pose2 a = random.pose();
    const Movement m = random.movement();
    const Pose2 b = applyMovement(a, m);
    const Movement f = movementRobotToField(a, m);
    ASSERT_NEAR(f.dx, b.x - a.x, 1e-9);
    ASSERT_NEAR(f.dy, b.y - a.y, 1e-9);
    ASSERT_NEAR(angleDiff(a.phi + f.dphi, b.phi), 0.0, 1e-9);
  }
}

TEST(IsFinite, DetectsNaNAndInfinity) {
  EXPECT_TRUE(isFinite(Pose2{1, 2, 3}));
  EXPECT_FALSE(isFinite(Pose2{std::numeric_limits<double>::quiet_NaN(), 0, 0}));
  EXPECT_FALSE(isFinite(Pose2{0, 0, std::numeric_limits<double>::infinity()}));
  EXPECT_TRUE(isFinite(Movement{1, 2, 30}));
  EXPECT_FALSE(isFinite(Movement{0, std::numeric_limits<double>::quiet_NaN(), 0}));
}

}  // namespace geometry_test
}  // namespace fieldline::geometry
