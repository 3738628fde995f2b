// The EKF steps (ekf.hpp): the pose update against the gyro heading, odometry prediction in
// parts, the push velocity's prediction.

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
#include "tests/unit/fusion/filter_inputs.hpp"

namespace fieldline::fusion {
namespace ekf_test {

using namespace filter_inputs;

// nees10h: a state carried to a time inside an odometry interval moves by that interval's own
// odometry (its motion and covariance in proportion), not by the velocity and the position
// density, and the part and the rest move exactly as the whole step.
OdometryStep turningStep(bool gyro) {
  const auto p = params();
  OdometryLayer layer(p);
  std::array<double, 4> rem{};
  layer.update({kStart, {0, 0, 0}, false});
  const robot::Twist twist{0.9, 0.3, 2.0};
  OdometrySample s{kStart + 20'000,
                   advanceTicks({0, 0, 0}, layer.kinematics(), p, twist, 0.02, rem), false};
  s.has_gyro = gyro;
  s.gyro_dphi = (2.0 + 0.01) * 0.02;
  OdometryStep step = *layer.update(s).step;
  EXPECT_EQ(step.gyro, gyro);
  return step;
}

// Seventh round: with the gyro's heading, a frame whose heading alone disagrees is weighted down
// to the Huber bound (SlipModel::gyro_heading_chi2); its position still counts in full.
TEST(UpdatePose, TheGyroHeadingOutweighsOneFrameHeadingButNotItsPosition) {
  const auto state = [](bool gyro) {
    EkfState s = startState();
    s.gyro = gyro;
    s.p.topLeftCorner<3, 3>() = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
    return s;
  };
  PoseMeasurement z;
  z.utime = kStart;
  const EkfState s0 = state(true);
  // 1 cm off in x, 0.1 rad (5.7 degrees) off in heading; the frame's heading sigma 0.015 rad.
  z.pose = {s0.x[0] + 0.01, s0.x[1], s0.x[2] + 0.1};
  z.covariance = Eigen::Vector3d(1e-4, 1e-4, 0.015 * 0.015).asDiagonal();
  z.robust_heading = true;
  SlipModel slip;
  slip.gyro_heading_chi2 = 9.0;
  const double gate2 = 16.27;

  EkfState robust = state(true);
  const UpdateResult r = updatePose(robust, z, gate2, slip);
  EXPECT_TRUE(r.accepted);
  EXPECT_TRUE(r.heading_weighted_down);
  EXPECT_FALSE(r.slip);
  EXPECT_NEAR(r.heading_innovation, 0.1, 1e-12);
  // The heading's variance was raised until the disagreement sits on the bound: the heading
  // moves by P * chi2 / y (0.009 rad), not by the Kalman share of the full 0.1 rad.
  EXPECT_NEAR(geometry::angleDiff(robust.x[2], s0.x[2]), 1e-4 * 9.0 / 0.1, 1e-9);
  // The position takes its usual share (equal variances: half way).
  EXPECT_NEAR(robust.x[0], s0.x[0] + 0.005, 1e-9);

  // The same frame without the weight (off, no gyro, or a heading confirmed by a second frame):
  // the whole disagreement counts and the gate refuses it.
  SlipModel off = slip;
  off.gyro_heading_chi2 = 0.0;
  EkfState plain = state(true);
  EXPECT_FALSE(updatePose(plain, z, gate2, off).accepted);
  EkfState wheels = state(false);
  const UpdateResult w = updatePose(wheels, z, gate2, slip);
  EXPECT_FALSE(w.accepted);
  EXPECT_FALSE(w.heading_weighted_down);
  PoseMeasurement confirmed = z;
  confirmed.robust_heading = false;
  EkfState taken = state(true);
  EXPECT_FALSE(updatePose(taken, confirmed, gate2, slip).accepted);
  // A heading within the bound is not touched: the same result as without the weight.
  PoseMeasurement small = z;
  small.pose.phi = s0.x[2] + 0.02;
  EkfState a = state(true);
  EkfState b = state(true);
  const UpdateResult ra = updatePose(a, small, gate2, slip);
  updatePose(b, small, gate2, off);
  EXPECT_FALSE(ra.heading_weighted_down);
  EXPECT_TRUE(a.x.isApprox(b.x, 1e-12));
  EXPECT_TRUE(a.p.isApprox(b.p, 1e-12));
}

TEST(UpdatePose, APushWithAWrongFrameHeadingWidensThePositionOnly) {
  EkfState s = startState();
  s.gyro = true;
  s.p.topLeftCorner<3, 3>() = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  const EkfState s0 = s;
  PoseMeasurement z;
  z.utime = kStart;
  // Pushed 30 cm; the frame's heading is 0.2 rad off as well.
  z.pose = {s0.x[0] + 0.3, s0.x[1], s0.x[2] + 0.2};
  z.covariance = Eigen::Vector3d(1e-4, 1e-4, 0.015 * 0.015).asDiagonal();
  z.robust_heading = true;
  z.may_reveal_slip = true;
  SlipModel slip;
  slip.max_m = 1.0;
  slip.max_rad_gyro = 1.2;
  slip.gyro_heading_chi2 = 9.0;
  const UpdateResult r = updatePose(s, z, 16.27, slip);
  ASSERT_TRUE(r.accepted);
  EXPECT_TRUE(r.slip);
  EXPECT_TRUE(r.heading_weighted_down);
  // The position follows the frame most of the way; the heading hardly moves and stays certain.
  EXPECT_GT(s.x[0], s0.x[0] + 0.29);
  EXPECT_LT(std::abs(geometry::angleDiff(s.x[2], s0.x[2])), 0.006);
  EXPECT_LE(s.p(2, 2), s0.p(2, 2));
  // Without the weight the slip widens the heading too and the heading follows the frame.
  EkfState t = s0;
  z.robust_heading = false;
  const UpdateResult q = updatePose(t, z, 16.27, slip);
  ASSERT_TRUE(q.slip);
  EXPECT_GT(geometry::angleDiff(t.x[2], s0.x[2]), 0.15);
}

TEST(PredictOdometry, APartAndTheRestMoveAsTheWholeStep) {
  ProcessNoise noise;
  noise.position_density = 1.0;  // would dominate if it were used
  noise.heading_density = 1.0;
  for (bool gyro : {false, true}) {
    OdometryStep step = turningStep(gyro);
    step.has_velocity = false;  // the velocity update depends on P, compared loosely below
    EkfState start = startState();
    start.x[kGyroBias] = 0.01;
    EkfState whole = start;
    predictOdometry(whole, step, noise);
    EkfState part = start;
    const Utime mid = step.t_start + 8'000;
    predictOdometryPart(part, step, mid, noise);
    EXPECT_EQ(part.utime, mid);
    EXPECT_EQ(part.gyro, gyro);
    // 40 % of the step's covariance, rotated into the field, and nothing of the densities.
    const double c = std::cos(start.x[2]), sn = std::sin(start.x[2]);
    Eigen::Matrix2d rot;
    rot << c, -sn, sn, c;
    const Eigen::Matrix2d grown = part.p.topLeftCorner<2, 2>() - start.p.topLeftCorner<2, 2>();
    const Eigen::Matrix2d expected =
        0.4 * rot * step.covariance.topLeftCorner<2, 2>() * rot.transpose();
    // F P F^T adds the heading's share (phi's 0.01 rad^2 times the lever of 40 % of the arc).
    EXPECT_LT((grown - expected).cwiseAbs().maxCoeff(), 0.011 * 0.4 * 0.4 * 0.02 * 0.02);
    EXPECT_LT(grown.trace(), 0.01 * noise.position_density * noise.position_density * 0.008);
    predictOdometry(part, step, noise);
    EXPECT_EQ(part.utime, whole.utime);
    EXPECT_LT((part.x - whole.x).cwiseAbs().maxCoeff(), 1e-12) << "gyro " << gyro;
    EXPECT_LT((part.p - whole.p).cwiseAbs().maxCoeff(), 1e-3 * whole.p.cwiseAbs().maxCoeff());
    EXPECT_GT(std::hypot(whole.x[0] - start.x[0], whole.x[1] - start.x[1]), 0.015);
  }
}

// A slip takes time: 33 ms after the last accepted correction the pose cannot be 60 cm off (a
// frame that says so matched an aliased line), 200 ms later it can (a push at 3 m/s).
TEST(UpdatePose, ASlipIsBoundedByTheTimeSinceTheLastCorrection) {
  SlipModel slip;
  slip.max_m = 1.0;
  slip.max_speed = 4.0;
  slip.base_m = 0.15;
  const auto run = [&](Utime since_correction_us, double offset_m) {
    EkfState s = startState();
    s.p.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 1e-4;
    s.last_correction_utime = kStart - since_correction_us;
    PoseMeasurement z;
    z.utime = kStart;
    z.pose = {s.x[0], s.x[1] + offset_m, s.x[2]};
    z.covariance = Eigen::Matrix3d::Identity() * 1e-4;
    z.may_reveal_slip = true;
    const EkfState before = s;
    const UpdateResult r = updatePose(s, z, 16.27, slip);
    return std::make_tuple(r, before, s);
  };
  // 0.15 + 4 * 0.033 = 0.28 m: 60 cm is refused and changes nothing.
  const auto [aliased, before, after] = run(33'000, 0.6);
  EXPECT_FALSE(aliased.accepted);
  EXPECT_EQ(after.x, before.x);
  EXPECT_EQ(after.p, before.p);
  // 25 cm within the same 33 ms is a push.
  EXPECT_TRUE(std::get<0>(run(33'000, 0.25)).slip);
  // 0.15 + 4 * 0.2 = 0.95 m: 60 cm after 200 ms without a correction is a push as well.
  const auto [pushed, b2, moved] = run(200'000, 0.6);
  EXPECT_TRUE(pushed.accepted);
  EXPECT_TRUE(pushed.slip);
  EXPECT_GT(moved.x[1], b2.x[1] + 0.5);
  // Never beyond max_m, however long ago.
  EXPECT_FALSE(std::get<0>(run(2'000'000, 1.2)).accepted);
  // Without max_speed, max_m alone: 60 cm after 33 ms is taken.
  slip.max_speed = 0.0;
  EXPECT_TRUE(std::get<0>(run(33'000, 0.6)).slip);
}

// push10i: the push velocity (PushModel, predictPush). Its process is the exact discretisation
// of an Ornstein-Uhlenbeck velocity integrated into the position, so two parts of an interval
// give the whole; off, it changes nothing.
TEST(PredictPush, TwoPartsGiveTheWholeAndOffChangesNothing) {
  PushModel push;
  push.density = 3.0;
  push.contact_decay_s = 0.5;
  push.free_decay_s = 0.1;
  EkfState start = startState();
  start.x[kPush] = 1.2;
  start.x[kPush + 1] = -0.4;
  start.p(kPush, kPush) = 0.3;
  start.p(kPush + 1, kPush + 1) = 0.2;
  start.p(0, kPush) = start.p(kPush, 0) = 0.01;
  for (double contact : {0.0, 1.0}) {
    EkfState whole = start;
    predictPush(whole, 0.02, 0.02 * contact, push);
    EkfState parts = start;
    predictPush(parts, 0.008, 0.008 * contact, push);
    predictPush(parts, 0.012, 0.012 * contact, push);
    EXPECT_LT((whole.x - parts.x).cwiseAbs().maxCoeff(), 1e-12) << contact;
    EXPECT_LT((whole.p - parts.p).cwiseAbs().maxCoeff(), 1e-12) << contact;
    // The push decays with its time constant and moves the position by its integral.
    const double tau = contact > 0.0 ? push.contact_decay_s : push.free_decay_s;
    const double a = std::exp(-0.02 / tau);
    EXPECT_NEAR(whole.x[kPush], 1.2 * a, 1e-12);
    EXPECT_NEAR(whole.x[0], start.x[0] + 1.2 * tau * (1.0 - a), 1e-12);
    EXPECT_NEAR(whole.x[1], start.x[1] - 0.4 * tau * (1.0 - a), 1e-12);
    // Noise only in contact: the Ornstein-Uhlenbeck variance over 20 ms.
    const double noise = contact > 0.0 ? 9.0 * tau / 2.0 * (1.0 - a * a) : 0.0;
    EXPECT_NEAR(whole.p(kPush, kPush), 0.3 * a * a + noise, 1e-12);
    EXPECT_NEAR(whole.p(kPush + 1, kPush + 1), 0.2 * a * a + noise, 1e-12);
  }
  // From no push and no spread, a long contact gives the random walk's variance, and the
  // position's grows as the integrated walk's (dt^3 / 3) while dt << the decay.
  EkfState walk = startState();
  predictPush(walk, 1e-3, 1e-3, push);
  EXPECT_NEAR(walk.p(kPush, kPush), 9.0 * 1e-3, 9.0 * 1e-3 * 0.01);
  EXPECT_NEAR(walk.p(0, 0) - startState().p(0, 0), 9.0 * 1e-9 / 3.0, 9.0 * 1e-9 * 0.01);
  EXPECT_GT(walk.p(0, kPush), 0.0);
  // The speed is held within max_speed (the direction kept); within it nothing changes.
  PushModel bounded = push;
  bounded.max_speed = 1.0;
  EkfState fast = start;
  predictPush(fast, 0.02, 0.02, bounded);
  EXPECT_NEAR(std::hypot(fast.x[kPush], fast.x[kPush + 1]), 1.0, 1e-12);
  EXPECT_NEAR(fast.x[kPush] / fast.x[kPush + 1], -3.0, 1e-9);
  bounded.max_speed = 2.0;
  EkfState slow = start;
  predictPush(slow, 0.02, 0.02, bounded);
  EkfState free_run = start;
  predictPush(free_run, 0.02, 0.02, push);
  EXPECT_EQ(slow.x, free_run.x);
  // In contact but long after the last accepted correction (unconfirmed_us): the push decays
  // as outside contact, with no noise; within the limit contact holds.
  PushModel confirmed_only = push;
  confirmed_only.unconfirmed_us = 150'000;
  EkfState stale = start;
  stale.last_correction_utime = stale.utime - 200'000;
  EkfState recent = stale;
  recent.last_correction_utime = recent.utime - 100'000;
  predictPush(stale, 0.02, 0.02, confirmed_only);
  predictPush(recent, 0.02, 0.02, confirmed_only);
  EkfState free_push = start;
  predictPush(free_push, 0.02, 0.0, push);
  EkfState contact_push = start;
  predictPush(contact_push, 0.02, 0.02, push);
  EXPECT_EQ(stale.x, free_push.x);
  EXPECT_EQ(stale.p, free_push.p);
  EXPECT_EQ(recent.x, contact_push.x);
  EXPECT_EQ(recent.p, contact_push.p);
  // Off: nothing moves.
  PushModel off = push;
  off.density = 0.0;
  EkfState same = start;
  predictPush(same, 0.02, 0.02, off);
  EXPECT_EQ(same.x, start.x);
  EXPECT_EQ(same.p, start.p);
}

}  // namespace ekf_test
}  // namespace fieldline::fusion
