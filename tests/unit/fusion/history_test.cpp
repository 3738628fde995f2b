// The delay-aware filter (DelayedFilter, history.hpp) on constructed inputs: late measurements
// inserted out of order give exactly the in-order state, bad inputs are refused, counted and
// change nothing, slips, contacts and pushes are found from the frames.

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
namespace history_test {

using namespace filter_inputs;

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

}  // namespace history_test
}  // namespace fieldline::fusion
