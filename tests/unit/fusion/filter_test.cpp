// The odometry layer and the delay-aware EKF on constructed inputs: late measurements inserted
// out of order give exactly the in-order state, bad inputs are refused, counted and change
// nothing, and the filter follows a pose measured with noise.
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

namespace fieldline::fusion {
namespace {

constexpr Utime kStart = 1'800'000'000'000'000;

robot::RobotParams params() {
  return robot::loadRobotPreset("fu2004");
}

// Ticks for a body twist held over dt, rounded like a real counter.
robot::TickCounts advanceTicks(const robot::TickCounts& ticks, const robot::OmniKinematics& kin,
                               const robot::RobotParams& p, const robot::Twist& twist, double dt,
                               std::array<double, 4>& remainder) {
  const robot::WheelVector wheel = kin.wheelAngularSpeeds(twist) * dt;
  robot::TickCounts out = ticks;
  for (std::size_t i = 0; i < ticks.size(); ++i) {
    const double exact =
        wheel[static_cast<int>(i)] / (2.0 * std::numbers::pi) * p.ticksPerWheelRevolution() +
        remainder[i];
    const double whole = std::round(exact);
    remainder[i] = exact - whole;
    out[i] =
        static_cast<std::int32_t>(static_cast<std::uint32_t>(ticks[i]) +
                                  static_cast<std::uint32_t>(static_cast<std::int64_t>(whole)));
  }
  return out;
}

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

struct Input {
  Utime arrival = 0;
  bool odometry = false;
  OdometryStep step;
  MeasurementSource source = MeasurementSource::kLines;
  PoseMeasurement z;
};

// A robot turning and accelerating for 3 s: odometry at 50 Hz (8 ms late), line measurements at
// 10 Hz and feature measurements at 5 Hz, each late by a random 0..150 ms. With `gyro` the
// odometry carries a gyro rotation with a bias of 0.004 rad/s.
std::vector<Input> makeInputs(std::mt19937& rng, bool gyro = false) {
  const auto p = params();
  OdometryLayer layer(p, test::bareOdometry());
  std::array<double, 4> rem{};
  robot::TickCounts ticks{0, 0, 0};
  layer.update({kStart, ticks, false});
  std::vector<Input> inputs;
  std::uniform_int_distribution<Utime> delay(0, 150'000);
  std::normal_distribution<double> noise(0.0, 0.03);
  geometry::Pose2 truth{-1.0, 0.5, 0.2};
  for (int k = 1; k <= 150; ++k) {
    const double t = k * 0.02;
    const robot::Twist twist{0.8 + 0.3 * std::sin(t), 0.2 * std::cos(2 * t), 0.6 * std::sin(t)};
    ticks = advanceTicks(ticks, layer.kinematics(), p, twist, 0.02, rem);
    const Utime utime = kStart + k * 20'000;
    OdometrySample sample{utime, ticks, false};
    sample.has_gyro = gyro;
    sample.gyro_dphi = (twist.omega + 0.004) * 0.02;
    const auto r = layer.update(sample);
    EXPECT_EQ(r.step->gyro, gyro);
    truth = geometry::applyMovement(truth, robot::arcMovement(twist.vector() * 0.02));
    Input in;
    in.arrival = utime + 8'000;
    in.odometry = true;
    in.step = *r.step;
    inputs.push_back(in);
    if (k % 5 == 2 || k % 10 == 7) {
      Input m;
      m.source = (k % 5 == 2) ? MeasurementSource::kLines : MeasurementSource::kFeatures;
      // Between odometry samples, as camera exposures are.
      m.z.utime = utime - 7'000;
      m.z.pose = {truth.x + noise(rng), truth.y + noise(rng), truth.phi + noise(rng)};
      m.z.covariance = Eigen::Vector3d(0.03 * 0.03, 0.05 * 0.05, 0.03 * 0.03).asDiagonal();
      m.z.covariance(0, 1) = m.z.covariance(1, 0) = 0.0005;
      m.arrival = m.z.utime + delay(rng);
      inputs.push_back(m);
    }
  }
  return inputs;
}

EkfState startState() {
  EkfState s;
  s.utime = kStart;
  s.x << -1.0, 0.5, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  s.p = (StateVector() << 0.01, 0.01, 0.01, 0.1, 0.1, 0.1, 1e-6, 0.0, 0.0).finished().asDiagonal();
  return s;
}

void feed(DelayedFilter& f, const Input& in, Utime now) {
  if (in.odometry) {
    EXPECT_EQ(f.addOdometry(in.step, now), Rejection::kNone);
  } else {
    f.addPose(in.source, in.z, now);
  }
}

Utime timeOf(const Input& in) {
  return in.odometry ? in.step.t_end : in.z.utime;
}

TEST(DelayedFilter, LateMeasurementsGiveTheInOrderStateExactly) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    // Half the runs with the gyro's heading and its bias state.
    std::vector<Input> inputs = makeInputs(rng, seed % 2 == 0);

    // In order of physical time, each input known when it happened.
    std::vector<Input> by_time = inputs;
    std::stable_sort(by_time.begin(), by_time.end(),
                     [](const Input& a, const Input& b) { return timeOf(a) < timeOf(b); });
    DelayedFilter in_order(test::bareFilter());
    in_order.initialize(startState());
    for (const Input& in : by_time)
      feed(in_order, in, timeOf(in));

    // In order of arrival: vision 0-150 ms late and shuffled against odometry and itself.
    std::vector<Input> by_arrival = inputs;
    std::stable_sort(by_arrival.begin(), by_arrival.end(),
                     [](const Input& a, const Input& b) { return a.arrival < b.arrival; });
    DelayedFilter late(test::bareFilter());
    late.initialize(startState());
    for (const Input& in : by_arrival)
      feed(late, in, in.arrival);

    EXPECT_GT(late.replays(), 0u);
    const EkfState& a = in_order.current();
    const EkfState& b = late.current();
    EXPECT_EQ(a.utime, b.utime);
    EXPECT_LT((a.x - b.x).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
    EXPECT_LT((a.p - b.p).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
    EXPECT_EQ(in_order.rejections(), late.rejections());
    // And the measurements did their job: the estimate is near the truth it was fed.
    EXPECT_GT(a.last_correction_utime, 0);
  }
}

// The twin's history: a filter mirrored through the centre spot halfway through, then fed the
// mirror images of the remaining measurements (odometry is in the robot frame, the same), ends
// exactly where a filter that saw the twin's measurements from the start ends. Late measurements
// after the mirror rewind into the mirrored past.
TEST(DelayedFilter, MirroredHalfwayEqualsTheTwinsHistoryExactly) {
  int seeds_replaying_across = 0;
  for (unsigned seed = 1; seed <= 8; ++seed) {
    std::mt19937 rng(seed);
    std::vector<Input> by_arrival = makeInputs(rng, seed % 2 == 0);
    std::stable_sort(by_arrival.begin(), by_arrival.end(),
                     [](const Input& a, const Input& b) { return a.arrival < b.arrival; });
    const auto mirrored = [](Input in) {
      if (!in.odometry) in.z = pointMirrored(in.z);
      return in;
    };
    DelayedFilter twin;
    twin.initialize(pointMirrored(startState()));
    for (const Input& in : by_arrival)
      feed(twin, mirrored(in), in.arrival);

    // Mirror where a measurement still in flight is older than one already fused, so that its
    // arrival replays measurements stored before the mirror.
    std::size_t half = 0;
    Utime newest_fused = 0;
    for (std::size_t i = 0; i < by_arrival.size() && half == 0; ++i) {
      if (i > by_arrival.size() / 4 && !by_arrival[i].odometry &&
          timeOf(by_arrival[i]) < newest_fused) {
        half = i;
      }
      if (!by_arrival[i].odometry) newest_fused = std::max(newest_fused, timeOf(by_arrival[i]));
    }
    if (half > 0) ++seeds_replaying_across;
    if (half == 0) half = by_arrival.size() / 2;
    DelayedFilter flipped(test::bareFilter());
    flipped.initialize(startState());
    for (std::size_t i = 0; i < by_arrival.size(); ++i) {
      if (i == half) flipped.mirrorThroughCentre();
      feed(flipped, i < half ? by_arrival[i] : mirrored(by_arrival[i]), by_arrival[i].arrival);
    }
    const EkfState& a = twin.current();
    const EkfState& b = flipped.current();
    EXPECT_LT((a.x - b.x).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
    EXPECT_LT((a.p - b.p).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
    EXPECT_EQ(twin.rejections(), flipped.rejections());
    // And the filter does not care which side it is on: the twin's history is the mirror image
    // of the original one.
    DelayedFilter original;
    original.initialize(startState());
    for (const Input& in : by_arrival)
      feed(original, in, in.arrival);
    const EkfState m = pointMirrored(original.current());
    EXPECT_LT((m.x - a.x).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
    EXPECT_LT((m.p - a.p).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
  }
  EXPECT_GE(seeds_replaying_across, 4);
  // Mirroring twice is the identity.
  const EkfState s = startState();
  const EkfState back = pointMirrored(pointMirrored(s));
  EXPECT_LT((s.x - back.x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((s.p - back.p).cwiseAbs().maxCoeff(), 1e-12);
}

// The slip bound depends on the state at the frame's time (its last correction), so a late frame
// that is refused as too far for the time it had, or taken as a slip, is decided the same way in
// any arrival order.
TEST(DelayedFilter, SlipDecisionsAreTheSameInAnyArrivalOrder) {
  FilterParams params = test::bareFilter();
  params.slip.max_m = 1.0;
  params.slip.max_speed = 4.0;
  params.slip.base_m = 0.15;
  params.slip.inflation = 2.0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng(seed);
    std::vector<Input> inputs = makeInputs(rng, seed % 2 == 0);
    // Every second line frame trusted and pushed 0.1-0.6 m off: beyond the gate, some within
    // the time bound and some not.
    std::uniform_real_distribution<double> off(0.1, 0.6);
    int n = 0;
    for (Input& in : inputs) {
      if (in.odometry || in.source != MeasurementSource::kLines || ++n % 2 != 0) continue;
      in.z.may_reveal_slip = true;
      in.z.pose.x += off(rng);
      in.z.covariance = Eigen::Matrix3d::Identity() * 1e-4;
    }
    const auto run = [&](bool by_arrival) {
      std::vector<Input> order = inputs;
      std::stable_sort(order.begin(), order.end(), [&](const Input& a, const Input& b) {
        return by_arrival ? a.arrival < b.arrival : timeOf(a) < timeOf(b);
      });
      DelayedFilter f(params);
      f.initialize(startState());
      for (const Input& in : order)
        feed(f, in, by_arrival ? in.arrival : timeOf(in));
      return f;
    };
    const DelayedFilter in_order = run(false);
    const DelayedFilter late = run(true);
    EXPECT_GT(late.replays(), 0u);
    EXPECT_LT((in_order.current().x - late.current().x).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((in_order.current().p - late.current().p).cwiseAbs().maxCoeff(), 1e-9);
    // (The rejection counters are not compared: they count each frame's decision on arrival,
    // and a frame that arrives before an older one may be decided again in the replay.)
    // The bound refused some frames.
    const auto gated = in_order.rejections()[static_cast<std::size_t>(Rejection::kGated)];
    EXPECT_GT(gated, 0u) << "seed " << seed;
  }
}

TEST(DelayedFilter, FollowsNoisyMeasurementsAgainstBiasedStart) {
  std::mt19937 rng(7);
  std::vector<Input> inputs = makeInputs(rng);
  DelayedFilter f(test::bareFilter());
  EkfState start = startState();
  start.x[0] += 0.3;  // 30 cm off
  start.p.topLeftCorner<3, 3>() = Eigen::Vector3d(0.25, 0.25, 0.05).asDiagonal();
  f.initialize(start);
  std::stable_sort(inputs.begin(), inputs.end(),
                   [](const Input& a, const Input& b) { return a.arrival < b.arrival; });
  for (const Input& in : inputs)
    feed(f, in, in.arrival);
  // The last few measurements are the truth plus 3 cm noise: the estimate sits near them.
  const Input* last = nullptr;
  for (const Input& in : inputs)
    if (!in.odometry && in.source == MeasurementSource::kLines) last = &in;
  ASSERT_NE(last, nullptr);
  const auto at = f.stateAt(last->z.utime);
  ASSERT_TRUE(at.has_value());
  EXPECT_LT(std::hypot(at->x[0] - last->z.pose.x, at->x[1] - last->z.pose.y), 0.12);
  EXPECT_EQ(f.rejections()[static_cast<std::size_t>(Rejection::kGated)], 0u);
}

TEST(DelayedFilter, RefusesBadInputsCountsThemAndChangesNothing) {
  std::mt19937 rng(3);
  std::vector<Input> inputs = makeInputs(rng);
  DelayedFilter f(test::bareFilter());
  f.initialize(startState());
  for (std::size_t i = 0; i < 60; ++i)
    if (inputs[i].odometry) feed(f, inputs[i], inputs[i].step.t_end + 8'000);
  const EkfState before = f.current();
  const Utime now = before.utime + 8'000;

  auto expectUnchanged = [&] {
    EXPECT_EQ(f.current().utime, before.utime);
    EXPECT_EQ(f.current().x, before.x);
    EXPECT_EQ(f.current().p, before.p);
  };
  auto count = [&](Rejection r) { return f.rejections()[static_cast<std::size_t>(r)]; };

  PoseMeasurement good;
  good.utime = before.utime - 50'000;
  good.pose = before.pose();
  good.covariance = Eigen::Matrix3d::Identity() * 1e-3;

  PoseMeasurement future = good;
  future.utime = now + 500'000;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, future, now).rejection, Rejection::kFromFuture);
  PoseMeasurement old = good;
  old.utime = before.utime - 1'500'000;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, old, now).rejection, Rejection::kTooOld);
  PoseMeasurement nan = good;
  nan.pose.y = std::nan("");
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, nan, now).rejection, Rejection::kNotFinite);
  PoseMeasurement not_pd = good;
  not_pd.covariance(0, 0) = -1e-3;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, not_pd, now).rejection,
            Rejection::kNotPositiveDefinite);
  PoseMeasurement asymmetric = good;
  asymmetric.covariance(0, 1) = 5e-4;
  EXPECT_EQ(f.addPose(MeasurementSource::kFeatures, asymmetric, now).rejection,
            Rejection::kNotPositiveDefinite);
  PoseMeasurement absurd = good;
  absurd.covariance(2, 2) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, absurd, now).rejection, Rejection::kNotFinite);
  OdometryStep bad_step = inputs[0].step;
  bad_step.integrated.x() = std::nan("");
  EXPECT_EQ(f.addOdometry(bad_step, now), Rejection::kNotFinite);
  OdometryStep dup_step = inputs[0].step;
  dup_step.t_start = before.utime - 20'000;
  dup_step.t_end = before.utime;
  EXPECT_EQ(f.addOdometry(dup_step, now), Rejection::kDuplicate);
  expectUnchanged();

  // Far off with a small covariance: refused by the gate (stored, but without effect).
  PoseMeasurement far = good;
  far.pose.x += 3.0;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, far, now).rejection, Rejection::kGated);
  EXPECT_LT((f.current().x - before.x).cwiseAbs().maxCoeff(), 1e-12);

  EXPECT_EQ(count(Rejection::kFromFuture), 1u);
  EXPECT_EQ(count(Rejection::kTooOld), 1u);
  EXPECT_EQ(count(Rejection::kNotFinite), 3u);
  EXPECT_EQ(count(Rejection::kNotPositiveDefinite), 2u);
  EXPECT_EQ(count(Rejection::kDuplicate), 1u);
  EXPECT_EQ(count(Rejection::kGated), 1u);

  // A good one still goes in and moves the estimate.
  PoseMeasurement moved = good;
  moved.utime = good.utime - 10'000;
  moved.pose = f.stateAt(moved.utime)->pose();
  moved.pose.x += 0.05;
  const auto accepted = f.addPose(MeasurementSource::kLines, moved, now);
  EXPECT_EQ(accepted.rejection, Rejection::kNone);
  EXPECT_GT(accepted.update.correction_m, 0.01);
  EXPECT_GT(f.current().x[0], before.x[0] + 0.01);
}

TEST(DelayedFilter, AngleWrapsAcrossPi) {
  DelayedFilter f(test::bareFilter());
  EkfState s = startState();
  s.x[2] = std::numbers::pi - 0.01;
  f.initialize(s);
  PoseMeasurement z;
  z.utime = s.utime + 10'000;
  z.pose = {s.x[0], s.x[1], -std::numbers::pi + 0.01};
  z.covariance = Eigen::Matrix3d::Identity() * 1e-4;
  const auto r = f.addPose(MeasurementSource::kLines, z, z.utime);
  EXPECT_EQ(r.rejection, Rejection::kNone);
  // The estimate moved across pi, not the long way round.
  EXPECT_GT(std::abs(f.current().x[2]), std::numbers::pi - 0.011);
  EXPECT_LT(r.update.correction_rad, 0.03);
}

TEST(DelayedFilter, InitializeReplaysStoredOdometry) {
  std::mt19937 rng(5);
  std::vector<Input> inputs = makeInputs(rng);
  DelayedFilter a;
  DelayedFilter b;
  a.initialize(startState());
  for (const Input& in : inputs) {
    if (!in.odometry) continue;
    feed(a, in, in.step.t_end);
    feed(b, in, in.step.t_end);
  }
  EXPECT_FALSE(b.initialized());
  b.initialize(startState());
  // Only the last second is kept: b starts from startState at kStart but its steps older than
  // the window were dropped, so compare against a filter that saw the same kept steps.
  EXPECT_TRUE(b.initialized());
  EXPECT_EQ(b.current().utime, a.current().utime);
}

}  // namespace
}  // namespace fieldline::fusion

namespace fieldline::fusion {
namespace {

// Slip (a collision odometry cannot see): a trusted measurement beyond the gate but within the
// slip limits widens the pose covariance and is applied; the same measurement untrusted, or
// beyond the limits, is refused by the gate and changes nothing.
TEST(DelayedFilter, TrustedFrameBeyondTheGateRevealsASlip) {
  const auto run = [](double offset_m, bool trusted) {
    DelayedFilter f(test::bareFilter());
    EkfState s = startState();
    s.p.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 1e-4;
    f.initialize(s);
    PoseMeasurement z;
    z.utime = s.utime + 10'000;
    z.pose = {s.x[0] + offset_m, s.x[1], s.x[2]};
    z.covariance = Eigen::Matrix3d::Identity() * 1e-4;
    z.may_reveal_slip = trusted;
    const auto r = f.addPose(MeasurementSource::kLines, z, z.utime + 50'000);
    return std::make_pair(r, f.current());
  };
  // 30 cm off against a 1 cm sigma: far beyond the gate.
  const auto [refused, unchanged] = run(0.3, false);
  EXPECT_EQ(refused.rejection, Rejection::kGated);
  EXPECT_GT(refused.update.mahalanobis2, 100.0);
  EXPECT_NEAR(unchanged.x[0], startState().x[0], 1e-12);

  const auto [slip, moved] = run(0.3, true);
  EXPECT_EQ(slip.rejection, Rejection::kNone);
  EXPECT_TRUE(slip.update.slip);
  // Most of the way to the measurement, which is now the better informed of the two.
  EXPECT_GT(moved.x[0], startState().x[0] + 0.2);
  // The covariance after the update is that of the measurement, not the old 1 cm.
  EXPECT_GT(moved.p(0, 0), 0.5e-4);

  // Beyond slip.max_m (0.5 m): a different place, not a slip.
  const auto [too_far, kept] = run(0.8, true);
  EXPECT_EQ(too_far.rejection, Rejection::kGated);
  EXPECT_NEAR(kept.x[0], startState().x[0], 1e-12);

  // Within the gate nothing changes: no slip is reported.
  const auto [normal, near_state] = run(0.02, true);
  EXPECT_EQ(normal.rejection, Rejection::kNone);
  EXPECT_FALSE(normal.update.slip);
  (void)near_state;
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

// Contact evidence (VISION_OBSTACLES showing an obstacle at the body) is an input like any other:
// inserted late and out of order it gives the in-order state exactly; while it covers an interval
// the pose's process noise grows by the contact densities over exactly the time covered.
FilterParams contactParams() {
  FilterParams p = test::bareFilter();
  p.contact.distance_m = 0.35;
  p.contact.hold_us = 300'000;
  p.contact.position_density = 0.2;
  p.contact.heading_density = 0.8;
  return p;
}

TEST(DelayedFilter, LateContactEvidenceGivesTheInOrderStateExactly) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng(seed);
    const std::vector<Input> inputs = makeInputs(rng);
    // Contact frames at 30 Hz in two bursts, each 60-200 ms late.
    std::vector<std::pair<Utime, Utime>> contacts;  // (utime, arrival)
    std::uniform_int_distribution<Utime> delay(60'000, 200'000);
    for (Utime t = kStart + 700'000; t < kStart + 1'000'000; t += 33'333)
      contacts.emplace_back(t, t + delay(rng));
    for (Utime t = kStart + 1'900'000; t < kStart + 2'100'000; t += 33'333)
      contacts.emplace_back(t, t + delay(rng));

    struct Event {
      Utime time;
      const Input* input;
      Utime contact;
    };
    std::vector<Event> by_time, by_arrival;
    for (const Input& in : inputs) {
      by_time.push_back({timeOf(in), &in, 0});
      by_arrival.push_back({in.arrival, &in, 0});
    }
    for (const auto& [t, arrival] : contacts) {
      by_time.push_back({t, nullptr, t});
      by_arrival.push_back({arrival, nullptr, t});
    }
    const auto order = [](const Event& a, const Event& b) { return a.time < b.time; };
    std::stable_sort(by_time.begin(), by_time.end(), order);
    std::stable_sort(by_arrival.begin(), by_arrival.end(), order);
    const auto run = [](const std::vector<Event>& events, const FilterParams& params) {
      DelayedFilter f(params);
      f.initialize(startState());
      for (const Event& e : events) {
        if (e.input) {
          feed(f, *e.input, e.time);
        } else {
          EXPECT_EQ(f.addContact(e.contact, e.time), Rejection::kNone);
        }
      }
      return f.current();
    };
    // Without and with the push velocity (PushModel), whose process depends on the contact.
    FilterParams with_push = contactParams();
    with_push.push.density = 3.0;
    for (const FilterParams& params : {contactParams(), with_push}) {
      const EkfState a = run(by_time, params);
      const EkfState b = run(by_arrival, params);
      EXPECT_EQ(a.utime, b.utime);
      EXPECT_LT((a.x - b.x).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
      EXPECT_LT((a.p - b.p).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
      // The push states moved with it, and only with it.
      if (params.push.density > 0.0) {
        EXPECT_GT(a.p(kPush, kPush), 0.0);
      } else {
        EXPECT_EQ(a.p(kPush, kPush), 0.0);
        EXPECT_EQ(a.x[kPush], 0.0);
      }
    }
  }
}

TEST(DelayedFilter, ContactGrowsThePoseNoiseOverTheTimeItCovers) {
  const auto p = params();
  OdometryLayer layer(p);
  const OdometryStep still = layer.stepFor({0, 0, 0}, 0.02);
  const auto run = [&](std::vector<Utime> contacts, DelayedFilter& f) {
    f.initialize(startState());
    for (Utime c : contacts)
      EXPECT_EQ(f.addContact(c, c), Rejection::kNone);
    for (int k = 1; k <= 50; ++k) {
      OdometryStep step = still;
      step.t_start = kStart + (k - 1) * 20'000;
      step.t_end = kStart + k * 20'000;
      EXPECT_EQ(f.addOdometry(step, step.t_end), Rejection::kNone);
    }
  };
  DelayedFilter untouched(contactParams());
  run({}, untouched);
  // Two frames 100 ms apart: covered from 200 ms to 600 ms (hold 300 ms), 0.4 s in all.
  DelayedFilter touched(contactParams());
  run({kStart + 200'000, kStart + 300'000}, touched);
  const double extra_phi = touched.current().p(2, 2) - untouched.current().p(2, 2);
  const double extra_x = touched.current().p(0, 0) - untouched.current().p(0, 0);
  EXPECT_NEAR(extra_phi, 0.8 * 0.8 * 0.4, 1e-9);
  EXPECT_NEAR(extra_x, 0.2 * 0.2 * 0.4, 1e-9);
  EXPECT_TRUE(touched.inContact(kStart + 550'000));
  EXPECT_FALSE(touched.inContact(kStart + 650'000));
  EXPECT_FALSE(touched.inContact(kStart + 100'000));
  EXPECT_FALSE(untouched.inContact(kStart + 300'000));

  // Refused and counted, changing nothing: a duplicate, from the future, older than the window.
  const EkfState before = touched.current();
  EXPECT_EQ(touched.addContact(kStart + 300'000, kStart + 1'000'000), Rejection::kDuplicate);
  EXPECT_EQ(touched.addContact(kStart + 2'000'000, kStart + 1'000'000), Rejection::kFromFuture);
  EXPECT_EQ(touched.addContact(kStart - 500'000, kStart + 1'000'000), Rejection::kTooOld);
  EXPECT_LT((touched.current().p - before.p).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(touched.rejections()[static_cast<std::size_t>(Rejection::kDuplicate)], 1u);
}

}  // namespace
}  // namespace fieldline::fusion

namespace fieldline::fusion {
namespace {

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

// A robot standing on its wheels and twisted at 0.5 rad/s (a collision): the wheels see nothing,
// the gyro sees the turn; the filter's heading follows the gyro between line frames.
TEST(DelayedFilter, AGyroFollowsATwistTheWheelsMiss) {
  const auto p = params();
  OdometryLayer with_gyro(p);
  OdometryLayer wheels(p);
  DelayedFilter fg(Localizer::withGyro(test::bareFilter(), p));
  DelayedFilter fw(test::bareFilter());
  fg.initialize(startState());
  fw.initialize(startState());
  with_gyro.update({kStart, {0, 0, 0}, false});
  wheels.update({kStart, {0, 0, 0}, false});
  for (int k = 1; k <= 25; ++k) {
    OdometrySample s{kStart + k * 20'000, {0, 0, 0}, false};
    s.has_gyro = true;
    s.gyro_dphi = 0.5 * 0.02;
    EXPECT_EQ(fg.addOdometry(*with_gyro.update(s).step, s.utime), Rejection::kNone);
    EXPECT_EQ(fw.addOdometry(*wheels.update({s.utime, s.ticks, false}).step, s.utime),
              Rejection::kNone);
  }
  const double truth = startState().x[2] + 0.25;
  EXPECT_NEAR(fg.current().x[2], truth, 1e-3);
  EXPECT_NEAR(fw.current().x[2], startState().x[2], 1e-3);
  EXPECT_TRUE(fg.current().gyro);
  EXPECT_FALSE(fw.current().gyro);
}

// Turning at 0.5 rad/s with a gyro biased by 0.006 rad/s (0.34 deg/s): the bias state learns it
// from line frames at 10 Hz (heading sigma 0.4 deg), and the heading stays right.
TEST(DelayedFilter, LearnsTheGyroBiasFromTheLineFrames) {
  const auto p = params();
  OdometryLayer layer(p, test::bareOdometry());
  DelayedFilter f(Localizer::withGyro(test::bareFilter(), p));
  EkfState start = startState();
  start.p(kGyroBias, kGyroBias) = p.gyro.bias_sigma * p.gyro.bias_sigma;
  f.initialize(start);
  layer.update({kStart, {0, 0, 0}, false});
  std::mt19937 rng(3);
  const double sigma = 0.007;
  std::normal_distribution<double> noise(0.0, sigma);
  const double bias = 0.006;
  double heading = start.x[2];
  for (int k = 1; k <= 1500; ++k) {  // 30 s
    const Utime utime = kStart + k * 20'000;
    OdometrySample s{utime, {0, 0, 0}, false};
    s.has_gyro = true;
    s.gyro_dphi = (0.5 + bias) * 0.02;
    heading += 0.5 * 0.02;
    ASSERT_EQ(f.addOdometry(*layer.update(s).step, utime), Rejection::kNone);
    if (k % 5 == 0) {
      PoseMeasurement z;
      z.utime = utime;
      z.pose = {start.x[0], start.x[1], geometry::normalizeAngle(heading + noise(rng))};
      z.covariance = Eigen::Vector3d(1e-4, 1e-4, sigma * sigma).asDiagonal();
      f.addPose(MeasurementSource::kLines, z, utime);
    }
  }
  EXPECT_NEAR(f.current().x[kGyroBias], bias, 0.001);
  EXPECT_LT(std::sqrt(f.current().p(kGyroBias, kGyroBias)), 0.002);
  EXPECT_NEAR(geometry::angleDiff(f.current().x[2], heading), 0.0, 3.0 * sigma);
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

TEST(DelayedFilter, AFrameInsideAnOdometryIntervalIsCarriedByItsOdometry) {
  const auto p = params();
  FilterParams fp = test::bareFilter();
  fp.noise.position_density = 0.5;  // large: a frame carried with it would show
  fp.noise.heading_density = 0.5;
  OdometryLayer layer(p);
  std::array<double, 4> rem{};
  robot::TickCounts ticks{0, 0, 0};
  layer.update({kStart, ticks, false});
  std::vector<OdometryStep> steps;
  for (int k = 1; k <= 10; ++k) {
    ticks = advanceTicks(ticks, layer.kinematics(), p, {1.0, -0.4, 1.2}, 0.02, rem);
    steps.push_back(*layer.update({kStart + k * 20'000, ticks, false}).step);
  }
  // A frame 40 % into the fifth step, 3 cm and 0.02 rad off the odometry's pose.
  const Utime t = steps[4].t_start + 8'000;
  PoseMeasurement z;
  z.utime = t;
  z.covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();

  // The state before the frame, by hand: the first four steps, then 40 % of the fifth.
  DelayedFilter four(fp);
  four.initialize(startState());
  for (int k = 0; k < 4; ++k)
    ASSERT_EQ(four.addOdometry(steps[static_cast<std::size_t>(k)], steps[3].t_end),
              Rejection::kNone);
  EkfState expected = four.current();
  predictOdometryPart(expected, steps[4], t, fp.noise);
  z.pose = {expected.x[0] + 0.03, expected.x[1], expected.x[2] + 0.02};

  // With every step known, stateAt(t) is that state, without the position density.
  DelayedFilter all(fp);
  all.initialize(startState());
  for (const OdometryStep& step : steps)
    ASSERT_EQ(all.addOdometry(step, steps.back().t_end), Rejection::kNone);
  const auto at = all.stateAt(t);
  ASSERT_TRUE(at.has_value());
  EXPECT_LT((at->x - expected.x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((at->p - expected.p).cwiseAbs().maxCoeff(), 1e-15);
  EkfState by_velocity = four.current();
  predictConstantVelocity(by_velocity, t, fp.noise);
  EXPECT_GT(by_velocity.p(0, 0) - at->p(0, 0), 0.5 * 0.5 * 0.008 * 0.9);
  // Beyond the newest step no odometry covers the time: the velocity and the density carry it.
  const auto beyond = all.stateAt(steps.back().t_end + 10'000);
  ASSERT_TRUE(beyond.has_value());
  EXPECT_GT(beyond->p(0, 0) - all.current().p(0, 0), 0.9 * 0.5 * 0.5 * 0.01);

  // The frame late (after all steps) and in order (before its step): the same state exactly,
  // and the one by hand: update at t, then the rest of the fifth step and the others.
  const auto late = all.addPose(MeasurementSource::kLines, z, steps.back().t_end + 60'000);
  ASSERT_EQ(late.rejection, Rejection::kNone);
  DelayedFilter in_order(fp);
  in_order.initialize(startState());
  for (std::size_t k = 0; k < steps.size(); ++k) {
    if (k == 4) {
      ASSERT_EQ(in_order.addPose(MeasurementSource::kLines, z, t).rejection, Rejection::kNone);
    }
    ASSERT_EQ(in_order.addOdometry(steps[k], steps[k].t_end), Rejection::kNone);
  }
  EkfState hand = expected;
  ASSERT_TRUE(updatePose(hand, z, fp.gate2, fp.slip).accepted);
  for (std::size_t k = 4; k < steps.size(); ++k)
    predictOdometry(hand, steps[k], fp.noise);
  for (const EkfState* s : {&all.current(), &in_order.current()}) {
    EXPECT_EQ(s->utime, hand.utime);
    EXPECT_LT((s->x - hand.x).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((s->p - hand.p).cwiseAbs().maxCoeff(), 1e-9);
  }
  EXPECT_EQ(all.current().last_correction_utime, t);
}

}  // namespace
}  // namespace fieldline::fusion

namespace fieldline::fusion {
namespace {

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

}  // namespace
}  // namespace fieldline::fusion

namespace fieldline::fusion {
namespace {

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

// A still robot (the wheels see nothing) carried by an opponent at 1.5 m/s in contact for 0.8 s,
// then left standing: frames at 30 Hz see the push. The push velocity learns it from the frames'
// corrections, so the state between frames carries the push on (the frames find it nearer than
// without the state), and after the contact the push decays to nothing.
struct PushRun {
  std::vector<double> innovations;  // position disagreement of each frame before its update, m
  double push_at_release = 0.0;     // ux at the end of the push (all frames in)
  EkfState end;
  DelayedFilter filter;
};

PushRun runPush(double density, bool late) {
  FilterParams fp = test::bareFilter();
  fp.contact.hold_us = 50'000;
  fp.contact.position_density = 0.2;
  fp.push.density = density;
  fp.push.contact_decay_s = 0.5;
  fp.push.free_decay_s = 0.1;
  const auto p = params();
  OdometryLayer layer(p);
  const OdometryStep still = layer.stepFor({0, 0, 0}, 0.02);
  PushRun run{{}, 0.0, {}, DelayedFilter(fp)};
  DelayedFilter& f = run.filter;
  EkfState start = startState();
  start.p.topLeftCorner<3, 3>() = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  f.initialize(start);
  const Utime push_from = kStart + 200'000, push_to = kStart + 1'000'000;
  // The truth's x: pushed at 1.5 m/s between push_from and push_to.
  const auto truth_x = [&](Utime t) {
    const Utime a = std::clamp(t, push_from, push_to);
    return start.x[0] + 1.5 * static_cast<double>(a - push_from) * 1e-6;
  };
  std::vector<PoseMeasurement> pending;
  Utime next_frame = kStart + 10'000;
  for (int k = 1; k <= 75; ++k) {
    const Utime t = kStart + k * 20'000;
    // The currents show the contact at every sample in the push.
    if (t > push_from && t <= push_to) {
      EXPECT_EQ(f.addContact(t - 20'000, t), Rejection::kNone);
    }
    OdometryStep step = still;
    step.t_start = t - 20'000;
    step.t_end = t;
    EXPECT_EQ(f.addOdometry(step, t), Rejection::kNone);
    for (; next_frame <= t; next_frame += 33'333) {
      PoseMeasurement z;
      z.utime = next_frame;
      z.pose = {truth_x(next_frame), start.x[1], start.x[2]};
      z.covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
      pending.push_back(z);
    }
    // Frames arrive 60 ms late (or at once).
    const Utime latency = late ? 60'000 : 0;
    while (!pending.empty() && pending.front().utime + latency <= t) {
      const PoseMeasurement z = pending.front();
      pending.erase(pending.begin());
      const auto prior = f.stateAt(z.utime);
      const auto r = f.addPose(MeasurementSource::kLines, z, t);
      EXPECT_EQ(r.rejection, Rejection::kNone) << "frame at " << (z.utime - kStart);
      if (z.utime > push_from + 300'000 && z.utime < push_to)
        run.innovations.push_back(std::abs(z.pose.x - prior->x[0]));
    }
  }
  // The last frames arrive after the last odometry.
  for (const PoseMeasurement& z : pending)
    EXPECT_EQ(f.addPose(MeasurementSource::kLines, z, z.utime + 60'000).rejection,
              Rejection::kNone);
  run.end = f.current();
  run.push_at_release = f.stateAt(push_to)->x[kPush];
  return run;
}

TEST(DelayedFilter, LearnsAPushFromTheFramesAndItDecaysAfterTheContact) {
  for (bool late : {false, true}) {
    const PushRun without = runPush(0.0, late);
    const PushRun with = runPush(4.0, late);
    ASSERT_FALSE(with.innovations.empty());
    const auto mean = [](const std::vector<double>& v) {
      double sum = 0.0;
      for (double x : v)
        sum += x;
      return sum / static_cast<double>(v.size());
    };
    // Without the state each frame finds the estimate about a frame interval of push behind
    // (1.5 m/s x 33 ms = 5 cm, less the share the contact noise lets it take); with it, the
    // push is carried on between frames.
    EXPECT_GT(mean(without.innovations), 0.02) << late;
    EXPECT_LT(mean(with.innovations), 0.5 * mean(without.innovations)) << late;
    EXPECT_NEAR(with.push_at_release, 1.5, 0.3) << late;
    EXPECT_EQ(without.push_at_release, 0.0);
    // Half a second after the release the push has decayed (free decay 0.1 s), and so has its
    // spread; the robot stands where the frames put it.
    EXPECT_LT(std::abs(with.end.x[kPush]), 0.05) << late;
    EXPECT_LT(with.end.p(kPush, kPush), 1e-3) << late;
    EXPECT_NEAR(with.end.x[0], -1.0 + 1.5 * 0.8, 0.02) << late;
  }
  // Late frames (60 ms) give exactly the state of frames processed at once.
  const PushRun at_once = runPush(4.0, false);
  const PushRun late = runPush(4.0, true);
  EXPECT_LT((at_once.end.x - late.end.x).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((at_once.end.p - late.end.p).cwiseAbs().maxCoeff(), 1e-9);
}

// With a push learnt, bad inputs are still refused, counted and change nothing.
TEST(DelayedFilter, WithAPushLearntBadInputsAreRefusedAndChangeNothing) {
  PushRun run = runPush(4.0, true);
  DelayedFilter& f = run.filter;
  const EkfState before = f.current();
  const Utime now = before.utime + 8'000;
  const auto rejections = f.rejections();
  PoseMeasurement good;
  good.utime = before.utime - 50'000;
  good.pose = f.stateAt(good.utime)->pose();
  good.covariance = Eigen::Matrix3d::Identity() * 1e-4;
  PoseMeasurement nan = good;
  nan.pose.x = std::nan("");
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, nan, now).rejection, Rejection::kNotFinite);
  PoseMeasurement future = good;
  future.utime = now + 500'000;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, future, now).rejection, Rejection::kFromFuture);
  PoseMeasurement old = good;
  old.utime = now - 1'500'000;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, old, now).rejection, Rejection::kTooOld);
  PoseMeasurement not_pd = good;
  not_pd.covariance(1, 1) = -1e-4;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, not_pd, now).rejection,
            Rejection::kNotPositiveDefinite);
  EXPECT_EQ(f.addContact(now + 500'000, now), Rejection::kFromFuture);
  PoseMeasurement far = good;
  far.pose.y += 2.0;
  EXPECT_EQ(f.addPose(MeasurementSource::kLines, far, now).rejection, Rejection::kGated);
  EXPECT_LT((f.current().x - before.x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((f.current().p - before.p).cwiseAbs().maxCoeff(), 1e-12);
  const auto& after = f.rejections();
  const auto delta = [&](Rejection r) {
    const auto i = static_cast<std::size_t>(r);
    return after[i] - rejections[i];
  };
  EXPECT_EQ(delta(Rejection::kNotFinite), 1u);
  EXPECT_EQ(delta(Rejection::kFromFuture), 2u);
  EXPECT_EQ(delta(Rejection::kTooOld), 1u);
  EXPECT_EQ(delta(Rejection::kNotPositiveDefinite), 1u);
  EXPECT_EQ(delta(Rejection::kGated), 1u);
}

}  // namespace
}  // namespace fieldline::fusion
