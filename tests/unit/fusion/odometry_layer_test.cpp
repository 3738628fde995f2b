// The odometry layer (odometry_layer.hpp): ticks to movements with their covariance, three or
// four wheels, a gyro, and bad samples refused.

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "common/robot/robot_params.hpp"
#include "services/fusion/history.hpp"
#include "services/fusion/localizer.hpp"
#include "services/fusion/odometry_layer.hpp"
#include "tests/unit/fusion/bare_params.hpp"
#include "tests/unit/fusion/filter_inputs.hpp"

namespace fieldline::fusion {
namespace odometry_layer_test {

using namespace filter_inputs;

TEST(OdometryLayer, StraightDriveAndWrappingCounters) {
  const auto p = params();
  OdometryLayer layer(p);
  std::array<double, 4> rem{};
  // Counters close to the int32 limit wrap during the drive.
  robot::TickCounts ticks{2'147'483'000, -2'147'483'000, 2'147'483'600};
  layer.update({kStart, ticks, false});
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  double last_var = 0.0;
  for (int k = 1; k <= 50; ++k) {
    ticks = advanceTicks(ticks, layer.kinematics(), p, {1.0, 0.0, 0.0}, 0.02, rem);
    const auto r = layer.update({kStart + k * 20'000, ticks, false});
    ASSERT_TRUE(r.step.has_value());
    EXPECT_EQ(r.rejection, OdometryRejection::kNone);
    total += r.step->integrated;
    last_var = r.step->covariance(0, 0);
  }
  EXPECT_NEAR(total.x(), 1.0, 0.01);
  EXPECT_NEAR(total.y(), 0.0, 0.01);
  EXPECT_NEAR(total.z(), 0.0, 0.01);
  // Faster driving: a larger step, a larger covariance.
  const auto still = layer.stepFor({0, 0, 0});
  EXPECT_GT(last_var, still.covariance(0, 0));
}

TEST(OdometryLayer, FourWheelsLeastSquaresAndTheirCovariance) {
  const auto p = robot::loadRobotPreset("four_wheel");
  OdometryLayer layer(p);
  std::array<double, 4> rem{};
  robot::TickCounts ticks{10, -20, 30, -2'147'483'600};
  layer.update({kStart, ticks, false});
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (int k = 1; k <= 50; ++k) {
    ticks = advanceTicks(ticks, layer.kinematics(), p, {0.6, -0.8, 0.5}, 0.02, rem);
    const auto r = layer.update({kStart + k * 20'000, ticks, false});
    ASSERT_TRUE(r.step.has_value());
    EXPECT_EQ(r.rejection, OdometryRejection::kNone);
    total += r.step->integrated;
  }
  EXPECT_NEAR(total.x(), 0.6, 0.005);
  EXPECT_NEAR(total.y(), -0.8, 0.005);
  EXPECT_NEAR(total.z(), 0.5, 0.005);

  // The covariance is the wheels' through the least-squares inverse: M^+ diag(var) M^+^T. One
  // more wheel averages the slip: driving the same 1 m forward in 20 ms steps, four wheels at
  // 45 degrees give a smaller position variance per metre than the seed's three.
  robot::TickDeltas one_metre;
  const robot::WheelVector rot = layer.kinematics().wheelAngularSpeeds({1.0, 0.0, 0.0});
  for (Eigen::Index i = 0; i < rot.size(); ++i)
    one_metre.push_back(std::llround(rot[i] * 768.0 / (2.0 * std::numbers::pi)));
  const OdometryStep four = layer.stepFor(one_metre, 1.0);
  EXPECT_NEAR(four.integrated.x(), 1.0, 0.002);
  const robot::WheelMatrixInverse& m_inv = layer.kinematics().robotMatrixInverse();
  robot::WheelVector ground(4);
  for (Eigen::Index i = 0; i < 4; ++i)
    ground[i] = static_cast<double>(one_metre[static_cast<std::size_t>(i)]) * 2.0 *
                std::numbers::pi * 0.04 / 768.0;
  const OdometryStep same = layer.stepForTravel(ground, 1.0);
  EXPECT_TRUE(same.covariance.isApprox(four.covariance, 1e-12));
  EXPECT_TRUE(same.integrated.isApprox(m_inv * ground, 1e-12));
  OdometryLayer three_layer(params());
  robot::TickDeltas three_metre;
  const robot::WheelVector rot3 = three_layer.kinematics().wheelAngularSpeeds({1.0, 0.0, 0.0});
  for (Eigen::Index i = 0; i < rot3.size(); ++i)
    three_metre.push_back(std::llround(rot3[i] * 768.0 / (2.0 * std::numbers::pi)));
  const OdometryStep three = three_layer.stepFor(three_metre, 1.0);
  EXPECT_LT(four.covariance(0, 0) + four.covariance(1, 1),
            three.covariance(0, 0) + three.covariance(1, 1));
  EXPECT_GT(four.covariance(0, 0), 0.0);

  // Ticks of three wheels for this four-wheeled robot: refused, nothing moves.
  const auto wrong = layer.update({kStart + 60 * 20'000, robot::TickCounts{1, 2, 3}, false});
  EXPECT_EQ(wrong.rejection, OdometryRejection::kWheelCount);
  EXPECT_FALSE(wrong.step.has_value());
  EXPECT_STREQ(toString(wrong.rejection), "odometry_wheel_count");
}

TEST(OdometryLayer, AControllerWithoutTicksGivesItsMovement) {
  // wheel_count 0: the controller's own movement per sample (a velocity-only controller).
  const auto p = params();
  OdometryLayer layer(p);
  OdometrySample s;
  s.utime = kStart;
  s.movement = {0.5, 0.5, 0.5};  // before the reference: not used
  EXPECT_FALSE(layer.update(s).step.has_value());
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (int k = 1; k <= 50; ++k) {
    s.utime = kStart + k * 20'000;
    s.movement = robot::arcMovement(Eigen::Vector3d(0.02, 0.004, 0.01));
    const auto r = layer.update(s);
    ASSERT_TRUE(r.step.has_value());
    EXPECT_TRUE(r.step->integrated.isApprox(Eigen::Vector3d(0.02, 0.004, 0.01), 1e-12));
    total += r.step->integrated;
    // The covariance of the wheel travel this movement implies.
    const OdometryStep expected =
        layer.stepForTravel(layer.kinematics().robotMatrix() * r.step->integrated, 0.02);
    EXPECT_TRUE(r.step->covariance.isApprox(expected.covariance, 1e-12));
  }
  EXPECT_NEAR(total.x(), 1.0, 1e-9);
  // A sample stamped before the reference keeps its movement for the next step.
  s.utime = kStart + 50 * 20'000 - 5'000;
  s.movement = {0.01, 0.0, 0.0};
  EXPECT_EQ(layer.update(s).rejection, OdometryRejection::kOutOfOrder);
  s.utime = kStart + 51 * 20'000;
  s.movement = {0.01, 0.0, 0.0};
  const auto r = layer.update(s);
  ASSERT_TRUE(r.step.has_value());
  EXPECT_NEAR(r.step->integrated.x(), 0.02, 1e-12);
  // A non-finite movement is refused; an impossible one is a jump.
  s.utime += 20'000;
  s.movement.dx = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(layer.update(s).rejection, OdometryRejection::kNotFinite);
  s.utime += 20'000;
  s.movement = {0.0, 0.0, 0.0};
  layer.update(s);
  s.utime += 20'000;
  s.movement = {5.0, 0.0, 0.0};
  EXPECT_EQ(layer.update(s).rejection, OdometryRejection::kJump);
  // Ticks after movements: no difference to take, the reference starts over.
  s.utime += 20'000;
  s.ticks = {0, 0, 0};
  EXPECT_EQ(layer.update(s).rejection, OdometryRejection::kWheelCount);
  s.utime += 20'000;
  EXPECT_TRUE(layer.update(s).step.has_value());
}

TEST(OdometryLayer, RefusesJumpsBackwardsTimeAndDuplicates) {
  const auto p = params();
  OdometryLayer layer(p);
  robot::TickCounts ticks{0, 0, 0};
  layer.update({kStart, ticks, false});
  EXPECT_EQ(layer.update({kStart, ticks, false}).rejection, OdometryRejection::kDuplicate);
  robot::TickCounts jump{100'000, 0, 0};
  const auto r = layer.update({kStart + 20'000, jump, false});
  EXPECT_EQ(r.rejection, OdometryRejection::kJump);
  EXPECT_FALSE(r.step.has_value());
  EXPECT_EQ(layer.update({kStart + 10'000, jump, false}).rejection, OdometryRejection::kOutOfOrder);
  // A slightly early stamp is refused but its ticks are not lost: the next step covers them.
  {
    OdometryLayer l2(p);
    l2.update({kStart, {0, 0, 0}, false});
    EXPECT_EQ(l2.update({kStart - 2'000, {10, 10, 10}, false}).rejection,
              OdometryRejection::kOutOfOrder);
    const auto next = l2.update({kStart + 20'000, {20, 20, 20}, false});
    ASSERT_TRUE(next.step.has_value());
    EXPECT_NEAR(next.step->integrated.z(), l2.stepFor({20, 20, 20}).integrated.z(), 1e-12);
  }
  EXPECT_EQ(layer.update({kStart + 30'000, jump, true}).rejection, OdometryRejection::kResync);
  // After the resync the reference is the new counter: small steps are movements again.
  const auto ok = layer.update({kStart + 50'000, {100'010, 0, 0}, false});
  ASSERT_TRUE(ok.step.has_value());
  EXPECT_EQ(ok.rejection, OdometryRejection::kNone);
}

TEST(OdometryLayer, TakesTheBridgesStampAsItIs) {
  // The bridge maps the controller's clock onto the host's (common/time/controller_clock.hpp);
  // layer 1 does not map it again: a controller time that disagrees changes no stamp.
  const auto p = params();
  OdometryLayer layer(p);
  std::mt19937 rng(9);
  std::uniform_int_distribution<Utime> jitter(0, 12'000);
  int steps = 0;
  Utime previous = 0;
  for (int k = 0; k < 50; ++k) {
    OdometrySample s;
    s.controller_utime = 5'000'000 + k * 20'000 + jitter(rng);
    s.utime = kStart + k * 20'000;
    s.ticks = {k, k, k};
    const auto r = layer.update(s);
    EXPECT_EQ(layer.lastStamp(), s.utime);
    if (r.step) {
      ++steps;
      EXPECT_EQ(r.step->t_start, previous);
      EXPECT_EQ(r.step->t_end, s.utime);
    }
    previous = s.utime;
  }
  EXPECT_EQ(steps, 49);
}

// The wheel-slip density: a short step is more uncertain relative to its length than a long one
// (white noise on the contact speed averages out), and the density adds to the per-metre terms.
TEST(OdometryLayer, SlipDensityGrowsWithTheSquareRootOfTime) {
  const auto p = params();
  OdometryNoise only_slip = test::bareOdometry();
  only_slip.wheel_relative_sigma = 0.0;
  only_slip.translation_sigma_per_m = 0.0;
  only_slip.rotation_sigma_per_rad = 0.0;
  only_slip.rotation_sigma_per_m = 0.0;
  only_slip.rotation_slip_density = 0.0;
  OdometryLayer layer(p, only_slip);
  // The same wheel travel in 20 ms and in 80 ms.
  const auto fast = layer.stepFor({40, -40, 0}, 0.02);
  const auto slow = layer.stepFor({40, -40, 0}, 0.08);
  ASSERT_GT(fast.integrated.head<2>().norm(), 0.01);
  const double ratio = std::sqrt(fast.covariance(0, 0) + fast.covariance(1, 1)) /
                       std::sqrt(slow.covariance(0, 0) + slow.covariance(1, 1));
  // Quantisation is a tiny part: the ratio is close to sqrt(80 / 20) = 2.
  EXPECT_NEAR(ratio, 2.0, 0.1);
  // Four 20 ms steps add up to twice the variance of one 80 ms step of the same total travel.
  const auto long_step = layer.stepFor({160, -160, 0}, 0.08);
  EXPECT_NEAR(4.0 * fast.covariance(0, 0) / long_step.covariance(0, 0), 1.0, 0.1);
  // Without the interval, the density drops out.
  const auto no_dt = layer.stepFor({40, -40, 0});
  EXPECT_LT(no_dt.covariance(0, 0), 0.01 * fast.covariance(0, 0));
}

TEST(OdometryLayer, TheGyroGivesTheHeadingAndBadValuesFallBackToTheWheels) {
  const auto p = params();
  ASSERT_TRUE(p.gyro.present);
  OdometryLayer layer(p, test::bareOdometry());
  std::array<double, 4> rem{};
  robot::TickCounts ticks{0, 0, 0};
  layer.update({kStart, ticks, false});
  Utime t = kStart;
  // Forward at 1 m/s with the wheels showing no turn; the gyro says 0.05 rad per 20 ms.
  const auto next = [&](bool has_gyro, double gyro_dphi) {
    ticks = advanceTicks(ticks, layer.kinematics(), p, {1.0, 0.0, 0.0}, 0.02, rem);
    t += 20'000;
    OdometrySample s{t, ticks, false};
    s.has_gyro = has_gyro;
    s.gyro_dphi = gyro_dphi;
    return layer.update(s);
  };
  auto r = next(true, 0.05);
  ASSERT_TRUE(r.step);
  EXPECT_TRUE(r.step->gyro);
  EXPECT_EQ(r.gyro_rejection, nullptr);
  EXPECT_DOUBLE_EQ(r.step->integrated.z(), 0.05);
  EXPECT_NEAR(r.step->integrated.x(), 0.02, 5e-4);
  // The heading's noise is the gyro's error model, independent of the wheels' translation.
  EXPECT_DOUBLE_EQ(r.step->covariance(2, 2), layer.gyroVariance(0.05, 0.02));
  EXPECT_EQ(r.step->covariance(0, 2), 0.0);
  EXPECT_EQ(r.step->covariance(2, 1), 0.0);
  const double wheel_var = layer.stepFor({0, 0, 0}, 0.02).covariance(2, 2);
  EXPECT_LT(r.step->covariance(2, 2), wheel_var);

  // Non-finite and absurd (beyond the gyro's range) values: counted, the wheels' heading used.
  r = next(true, std::numeric_limits<double>::quiet_NaN());
  ASSERT_TRUE(r.step);
  EXPECT_STREQ(r.gyro_rejection, "gyro_not_finite");
  EXPECT_FALSE(r.step->gyro);
  EXPECT_NEAR(r.step->integrated.z(), 0.0, 1e-3);
  r = next(true, 5.0);  // 250 rad/s
  ASSERT_TRUE(r.step);
  EXPECT_STREQ(r.gyro_rejection, "gyro_absurd");
  EXPECT_FALSE(r.step->gyro);
  // Without STATUS_GYRO: the wheels, nothing counted.
  r = next(false, 0.05);
  ASSERT_TRUE(r.step);
  EXPECT_FALSE(r.step->gyro);
  EXPECT_EQ(r.gyro_rejection, nullptr);

  // A sample stamped before the reference gives no step, but its rotation is not lost: the next
  // step carries both.
  r = next(true, 0.03);
  ASSERT_TRUE(r.step->gyro);
  OdometrySample early{t - 5'000, ticks, false};
  early.has_gyro = true;
  early.gyro_dphi = 0.01;
  EXPECT_EQ(layer.update(early).rejection, OdometryRejection::kOutOfOrder);
  r = next(true, 0.02);
  ASSERT_TRUE(r.step);
  EXPECT_TRUE(r.step->gyro);
  EXPECT_NEAR(r.step->integrated.z(), 0.03, 1e-12);

  // use_gyro false: the wheels, as without a gyro.
  OdometryNoise wheels_only = test::bareOdometry();
  wheels_only.use_gyro = false;
  OdometryLayer off(p, wheels_only);
  off.update({kStart, {0, 0, 0}, false});
  OdometrySample s{kStart + 20'000, {0, 0, 0}, false};
  s.has_gyro = true;
  s.gyro_dphi = 0.05;
  const auto w = off.update(s);
  ASSERT_TRUE(w.step);
  EXPECT_FALSE(w.step->gyro);
  EXPECT_EQ(w.step->integrated.z(), 0.0);
  // And a robot file without a gyro section: the wheels too.
  auto no_gyro = p;
  no_gyro.gyro.present = false;
  OdometryLayer bare(no_gyro);
  bare.update({kStart, {0, 0, 0}, false});
  EXPECT_FALSE(bare.update(s).step->gyro);
}

}  // namespace odometry_layer_test
}  // namespace fieldline::fusion
