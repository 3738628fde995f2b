// Clock offsets from synthetic round trips: two robots exchange packets at 20 Hz through a link
// with its own delay distribution per direction; robot B's clock runs ahead by an offset that
// drifts. The estimator sees exactly what the packets carry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "teamcomm/clock_offset.hpp"

namespace fieldline::teamcomm {
namespace clock_offset_test {

constexpr Utime kT0 = 1'700'000'000'000'000;

struct Link {
  double offset_us = 0.0;                            // B's clock minus A's at kT0
  double drift_ppm = 0.0;                            // B's clock rate error relative to A's
  std::function<double(std::mt19937&)> delay_ab_us;  // A -> B one-way delay
  std::function<double(std::mt19937&)> delay_ba_us;  // B -> A
  double loss = 0.0;
  double trueOffset(double a_time) const {
    return offset_us + drift_ppm * 1e-6 * (a_time - static_cast<double>(kT0));
  }
};

// Runs `seconds` of traffic into `est` (robot A's estimator of B); returns A's time at the end.
Utime simulate(const Link& link, double seconds, ClockOffsetEstimator& est, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  struct Arrival {
    double t1_a;  // A's send time (A's clock = true time here)
    double t2_b;  // B's receive time on B's clock
    double at;    // true arrival time
  };
  std::vector<Arrival> at_b;
  const double period = 50'000.0;
  const double end = static_cast<double>(kT0) + seconds * 1e6;
  // A's packets to B.
  for (double t = static_cast<double>(kT0) + 7'000.0; t < end; t += period) {
    if (unit(rng) < link.loss) continue;
    const double arrive = t + link.delay_ab_us(rng);
    at_b.push_back({t, arrive + link.trueOffset(arrive), arrive});
  }
  // B's packets to A, each echoing the last A packet B had received.
  std::size_t next = 0;
  const Arrival* last = nullptr;
  for (double t = static_cast<double>(kT0) + 31'000.0; t < end; t += period) {
    while (next < at_b.size() && at_b[next].at <= t)
      last = &at_b[next++];
    if (!last || unit(rng) < link.loss) continue;
    const double arrive = t + link.delay_ba_us(rng);
    RoundTrip rt{static_cast<Utime>(last->t1_a), static_cast<Utime>(last->t2_b),
                 static_cast<Utime>(t + link.trueOffset(t)), static_cast<Utime>(arrive)};
    est.add(rt);
  }
  return static_cast<Utime>(end);
}

double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

TEST(teamcomm_clock_offset, FindsAConstantOffsetThroughAsymmetricJitter) {
  Link link;
  link.offset_us = 437'000.0;
  // Both directions 1-20 ms, but A->B mostly slow (queueing) and B->A mostly fast.
  link.delay_ab_us = [](std::mt19937& r) {
    return 1000.0 + std::min(19'000.0, std::exponential_distribution<double>(1.0 / 8000.0)(r));
  };
  link.delay_ba_us = [](std::mt19937& r) { return uniform(r, 1000.0, 4000.0); };
  ClockOffsetEstimator est;
  const Utime now = simulate(link, 12.0, est, 1);
  const auto e = est.estimate(now);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->offset_us, link.trueOffset(static_cast<double>(now)), 300.0);
  // The mean-delay estimate would be off by (9 - 2.5) / 2 ms: the minimum filter is what works.
  EXPECT_LT(e->min_round_trip_us, 3000);
  EXPECT_GE(e->min_round_trip_us, 2000);
  EXPECT_NEAR(e->uncertainty_us, 0.5 * static_cast<double>(e->min_round_trip_us), 1e-9);
}

TEST(teamcomm_clock_offset, FollowsDriftWithALineFit) {
  Link link;
  link.offset_us = -480'000.0;
  link.drift_ppm = 50.0;
  link.delay_ab_us = [](std::mt19937& r) { return uniform(r, 1000.0, 20'000.0); };
  link.delay_ba_us = [](std::mt19937& r) { return uniform(r, 1000.0, 20'000.0); };
  ClockOffsetEstimator est;
  const Utime now = simulate(link, 60.0, est, 2);
  const auto e = est.estimate(now);
  ASSERT_TRUE(e);
  // 50 ppm over a 20 s window is 1 ms: without the fit the newest offset would be 0.5 ms off.
  EXPECT_NEAR(e->offset_us, link.trueOffset(static_cast<double>(now)), 300.0);
  EXPECT_NEAR(e->drift_ppm, 50.0, 15.0);
  // And predicted a second ahead.
  EXPECT_NEAR(est.estimate(now + 1'000'000)->offset_us,
              link.trueOffset(static_cast<double>(now + 1'000'000)), 350.0);
}

TEST(teamcomm_clock_offset, SurvivesHeavyLossAndConvertsTimesBothWays) {
  Link link;
  link.offset_us = 123'456.0;
  link.drift_ppm = -30.0;
  link.loss = 0.3;
  // WiFi-like: most packets near the minimum, a long queueing tail (capped at 20 ms).
  link.delay_ab_us = [](std::mt19937& r) {
    return 1000.0 + std::min(19'000.0, std::exponential_distribution<double>(1.0 / 3000.0)(r));
  };
  link.delay_ba_us = [](std::mt19937& r) {
    return 1000.0 + std::min(19'000.0, std::exponential_distribution<double>(1.0 / 5000.0)(r));
  };
  ClockOffsetEstimator est;
  const Utime now = simulate(link, 15.0, est, 3);
  const auto e = est.estimate(now);
  ASSERT_TRUE(e);
  const double truth = link.trueOffset(static_cast<double>(now));
  EXPECT_NEAR(e->offset_us, truth, 500.0);
  const Utime theirs = now + static_cast<Utime>(truth);
  EXPECT_NEAR(static_cast<double>(*est.toOurs(theirs)), static_cast<double>(now), 500.0);
  EXPECT_NEAR(static_cast<double>(*est.toTheirs(now)), static_cast<double>(theirs), 500.0);
}

TEST(teamcomm_clock_offset, AFixedAsymmetryIsAnErrorOfHalfOfIt) {
  // No round-trip method can see a constant asymmetry: 3 ms one way, 1 ms back is read as a
  // 1 ms offset error. That is the documented limit; the estimate stays within it.
  Link link;
  link.offset_us = 10'000.0;
  link.delay_ab_us = [](std::mt19937& r) { return uniform(r, 3000.0, 3100.0); };
  link.delay_ba_us = [](std::mt19937& r) { return uniform(r, 1000.0, 1100.0); };
  ClockOffsetEstimator est;
  const Utime now = simulate(link, 5.0, est, 4);
  EXPECT_NEAR(est.estimate(now)->offset_us, link.offset_us + 1000.0, 100.0);
}

TEST(teamcomm_clock_offset, IgnoresImpossibleRoundTripsAndForgetsOldOnes) {
  ClockOffsetEstimator est({.window_us = 5'000'000});
  EXPECT_FALSE(est.estimate(kT0));
  // Negative round trip: the echo does not match our send.
  EXPECT_EQ(est.add({kT0, kT0 + 5000, kT0 + 50'000, kT0 + 10'000}), RoundTripUse::kRefused);
  // Round trip of 2 s: queueing, not clock information.
  EXPECT_EQ(est.add({kT0, kT0 + 1000, kT0 + 2000, kT0 + 2'000'000}), RoundTripUse::kRefused);
  // Hold time negative.
  EXPECT_EQ(est.add({kT0, kT0 + 5000, kT0 + 4000, kT0 + 6000}), RoundTripUse::kRefused);
  EXPECT_EQ(est.add({kT0, kT0 + 2000, kT0 + 3000, kT0 + 2000}),
            RoundTripUse::kAdded);  // offset +1500, rtt 1000
  EXPECT_NEAR(est.estimate(kT0)->offset_us, 1500.0, 1e-9);
  EXPECT_EQ(est.estimate(kT0)->min_round_trip_us, 1000);
  // Ten seconds later a clock that has jumped by 0.2 s: the old sample has left the window.
  const Utime later = kT0 + 10'000'000;
  EXPECT_EQ(est.add({later, later + 202'000, later + 203'000, later + 4000}), RoundTripUse::kAdded);
  EXPECT_EQ(est.samples(), 1u);
  EXPECT_NEAR(est.estimate(later)->offset_us, 200'500.0, 1e-9);
}

// A round trip with symmetric 1 ms delays at our time `t` against a teammate `offset` ahead.
RoundTrip tripAt(Utime t, Utime offset) {
  return {t - 2000, t - 1000 + offset, t - 1000 + offset + 100, t + 100};
}

TEST(teamcomm_clock_offset, OneBadRoundTripIsHeldAsideAndForgotten) {
  ClockOffsetEstimator est;
  for (Utime t = kT0; t < kT0 + 2'000'000; t += 50'000)
    ASSERT_EQ(est.add(tripAt(t, 300'000)), RoundTripUse::kAdded);
  // A teammate's stamp off by 0.5 s once: held, not fitted.
  EXPECT_EQ(est.add(tripAt(kT0 + 2'000'000, 800'000)), RoundTripUse::kHeld);
  EXPECT_EQ(est.held(), 1u);
  EXPECT_NEAR(est.estimate(kT0 + 2'000'000)->offset_us, 300'000.0, 1.0);
  // The next good one clears it.
  EXPECT_EQ(est.add(tripAt(kT0 + 2'050'000, 300'000)), RoundTripUse::kAdded);
  EXPECT_EQ(est.held(), 0u);
  EXPECT_EQ(est.steps(), 0u);
  // Two contradicting ones that disagree with each other are no step either.
  EXPECT_EQ(est.add(tripAt(kT0 + 2'100'000, 800'000)), RoundTripUse::kHeld);
  EXPECT_EQ(est.add(tripAt(kT0 + 2'150'000, -900'000)), RoundTripUse::kHeld);
  EXPECT_EQ(est.held(), 1u);  // the older went: the two share no offset
  EXPECT_FALSE(est.converging());
}

TEST(teamcomm_clock_offset, ThreeAgreeingContradictionsAreAStepAndTheFitRestarts) {
  for (const Utime step : {Utime{2'000'000}, Utime{-2'000'000}, Utime{20'000}}) {
    ClockOffsetEstimator est;
    Utime t = kT0;
    for (; t < kT0 + 5'000'000; t += 50'000)
      ASSERT_EQ(est.add(tripAt(t, 300'000)), RoundTripUse::kAdded);
    EXPECT_EQ(est.add(tripAt(t, 300'000 + step)), RoundTripUse::kHeld) << step;
    EXPECT_EQ(est.add(tripAt(t + 50'000, 300'000 + step)), RoundTripUse::kHeld) << step;
    EXPECT_EQ(est.add(tripAt(t + 100'000, 300'000 + step)), RoundTripUse::kStep) << step;
    EXPECT_EQ(est.steps(), 1u);
    EXPECT_EQ(est.samples(), 3u);
    EXPECT_NEAR(est.lastStep()->size_us, static_cast<double>(step), 1.0);
    EXPECT_NEAR(est.estimate(t + 100'000)->offset_us, 300'000.0 + static_cast<double>(step), 1.0);
    // Converging until the new window spans the drift fit's 3 s.
    EXPECT_TRUE(est.converging());
    for (t += 150'000; t < kT0 + 8'200'000; t += 50'000)
      ASSERT_EQ(est.add(tripAt(t, 300'000 + step)), RoundTripUse::kAdded);
    EXPECT_FALSE(est.converging());
  }
}

// The fit as it was made before issue 32's incremental envelopes: every round trip, both
// directions' points sorted afresh and their whole lower hulls built, over the window's round
// trips.
struct BatchFit {
  double intercept_us = 0.0;
  double slope = 0.0;
  Utime reference = 0;
  Utime min_round_trip_us = 0;
};

std::pair<double, double> batchEnvelope(std::vector<std::pair<double, double>> points,
                                        bool fit_slope, double max_slope) {
  std::sort(points.begin(), points.end());
  double t_mean = 0.0;
  for (const auto& p : points)
    t_mean += p.first;
  t_mean /= static_cast<double>(points.size());
  if (!fit_slope || points.size() < 2) {
    double lowest = points.front().second;
    for (const auto& p : points)
      lowest = std::min(lowest, p.second);
    return {lowest, 0.0};
  }
  std::vector<std::pair<double, double>> hull;
  for (const auto& p : points) {
    while (hull.size() >= 2) {
      const auto& o = hull[hull.size() - 2];
      const auto& a = hull.back();
      const double cross =
          (a.first - o.first) * (p.second - o.second) - (a.second - o.second) * (p.first - o.first);
      if (cross > 0.0) break;
      hull.pop_back();
    }
    if (!hull.empty() && hull.back().first == p.first) {
      if (p.second < hull.back().second) hull.back() = p;
      continue;
    }
    hull.push_back(p);
  }
  std::size_t i = 0;
  while (i + 2 < hull.size() && hull[i + 1].first < t_mean)
    ++i;
  if (hull.size() < 2) return {hull.front().second, 0.0};
  const auto& a = hull[i];
  const auto& b = hull[i + 1];
  const double slope =
      std::clamp((b.second - a.second) / (b.first - a.first), -max_slope, max_slope);
  return {std::min(a.second - slope * a.first, b.second - slope * b.first), slope};
}

BatchFit batchFit(const std::deque<RoundTrip>& window, const OffsetOptions& o) {
  BatchFit fit;
  fit.reference = window.back().t4_our_receive;
  std::vector<std::pair<double, double>> forward, backward;
  fit.min_round_trip_us = std::numeric_limits<Utime>::max();
  for (const RoundTrip& rt : window) {
    forward.emplace_back(static_cast<double>(rt.t1_our_send - fit.reference),
                         static_cast<double>(rt.t2_their_receive - rt.t1_our_send));
    backward.emplace_back(static_cast<double>(rt.t4_our_receive - fit.reference),
                          -static_cast<double>(rt.t3_their_send - rt.t4_our_receive));
    const Utime trip =
        (rt.t4_our_receive - rt.t1_our_send) - (rt.t3_their_send - rt.t2_their_receive);
    fit.min_round_trip_us = std::min(fit.min_round_trip_us, std::max<Utime>(trip, 0));
  }
  const bool fit_slope =
      window.size() >= 3 &&
      window.back().t4_our_receive - window.front().t4_our_receive >= o.min_fit_span_us;
  const auto up = batchEnvelope(forward, fit_slope, o.max_drift_ppm * 1e-6);
  const auto down = batchEnvelope(backward, fit_slope, o.max_drift_ppm * 1e-6);
  fit.intercept_us = 0.5 * (up.first - down.first);
  fit.slope = 0.5 * (up.second - down.second);
  return fit;
}

// 18,000 seeded round trips (six teammates' links of 150 s at 20 Hz: jitter, asymmetric delays,
// drift, losses that make a teammate echo the same packet of ours twice, round trips arriving out
// of order, a teammate silent for longer than the window): the incremental envelopes give, round
// trip by round trip, the very numbers the batch fit gives over the same window.
TEST(teamcomm_clock_offset, IncrementalEnvelopesGiveTheBatchFitExactly) {
  int compared = 0;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed);
    const OffsetOptions options;
    ClockOffsetEstimator est(options);
    std::deque<RoundTrip> window;
    const double offset = uniform(rng, -1e6, 1e6);
    const double drift_ppm = uniform(rng, -200.0, 200.0);
    std::vector<RoundTrip> trips;
    Utime last_t1 = kT0;
    for (int i = 0; i < 3000; ++i) {
      // A silence of 25 s after 100 s: the window restarts.
      const Utime t4 = kT0 + i * Utime{50'000} + (i >= 2000 ? Utime{25'000'000} : 0) +
                       static_cast<Utime>(uniform(rng, 0.0, 3000.0));
      const double there = 300.0 + std::exponential_distribution<double>(1.0 / 900.0)(rng);
      const double back = 500.0 + std::exponential_distribution<double>(1.0 / 400.0)(rng);
      const Utime t3_ours = t4 - static_cast<Utime>(back);
      // Our packet it echoes: the newest it got, or (lost) the one before again.
      Utime t1 =
          t3_ours - static_cast<Utime>(uniform(rng, 2000.0, 40'000.0)) - static_cast<Utime>(there);
      if (uniform(rng, 0.0, 1.0) < 0.2) t1 = std::min(last_t1, t1);
      last_t1 = t1;
      const auto theirs = [&](double ours) {
        return static_cast<Utime>(
            std::llround(ours + offset + drift_ppm * 1e-6 * (ours - static_cast<double>(kT0))));
      };
      trips.push_back(
          {t1, theirs(static_cast<double>(t1) + there), theirs(static_cast<double>(t3_ours)), t4});
    }
    // Now and then two round trips arrive the other way round.
    for (std::size_t i = 1; i < trips.size(); ++i) {
      if (uniform(rng, 0.0, 1.0) < 0.05) std::swap(trips[i], trips[i - 1]);
    }
    for (const RoundTrip& rt : trips) {
      const bool plausible = est.plausible(rt);
      if (plausible) {
        const Utime newest = window.empty()
                                 ? rt.t4_our_receive
                                 : std::max(rt.t4_our_receive, window.back().t4_our_receive);
        while (!window.empty() && window.front().t4_our_receive < newest - options.window_us)
          window.pop_front();
      }
      const RoundTripUse use = est.add(rt);
      ASSERT_EQ(use, plausible ? RoundTripUse::kAdded : RoundTripUse::kRefused);
      if (!plausible) continue;
      window.push_back(rt);
      for (std::size_t i = window.size() - 1;
           i > 0 && window[i].t4_our_receive < window[i - 1].t4_our_receive; --i) {
        std::swap(window[i], window[i - 1]);
      }
      const BatchFit fit = batchFit(window, options);
      const Utime at = rt.t4_our_receive + 10'000;
      const auto e = est.estimate(at);
      ASSERT_TRUE(e);
      ASSERT_EQ(e->offset_us,
                fit.intercept_us + fit.slope * static_cast<double>(at - fit.reference))
          << "seed " << seed << " round trip " << compared;
      ASSERT_EQ(e->drift_ppm, fit.slope * 1e6);
      ASSERT_EQ(e->min_round_trip_us, fit.min_round_trip_us);
      ++compared;
    }
  }
  EXPECT_GT(compared, 17'000);
}

}  // namespace clock_offset_test
}  // namespace fieldline::teamcomm
