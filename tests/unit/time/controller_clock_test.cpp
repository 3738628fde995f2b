// ControllerClockMap: the controller's clock on the host's, without the serial link's jitter,
// through controller restarts, host clock steps, a starved reader and drift.
#include "common/time/controller_clock.hpp"

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace fieldline {
namespace controller_clock_test {

constexpr Utime kHost0 = 1'800'000'000'000'000;
constexpr Utime kLatency = 8'000;
// Controller time 0 is this host time; the fastest path takes kLatency from sampling to receipt.
constexpr Utime kOffset = kHost0 - 3'000'000;

ControllerClockMap::Params params() {
  ControllerClockMap::Params p;
  p.latency_us = kLatency;
  return p;
}

TEST(ControllerClock, StampsTheSamplingTimeWithoutTheLinksJitter) {
  ControllerClockMap map(params());
  std::mt19937 rng(3);
  // The link delays a sample by 0-6 ms beyond the fastest path.
  std::uniform_int_distribution<int> jitter(0, 6'000);
  double worst_after_1s = 0.0;
  double worst_receive = 0.0;
  for (int k = 0; k < 500; ++k) {
    const std::int64_t device = 3'000'000 + 20'000 * k;
    const Utime sampled = kOffset + device;
    const Utime received = sampled + kLatency + jitter(rng);
    map.observe(device, received);
    const Utime stamp = *map.stamp(device);
    EXPECT_LE(std::abs(stamp - sampled), 6'000);
    if (k >= 50) {
      worst_after_1s = std::max(worst_after_1s, std::abs(static_cast<double>(stamp - sampled)));
      worst_receive =
          std::max(worst_receive, std::abs(static_cast<double>(received - kLatency - sampled)));
    }
  }
  // The envelope has met a near-fastest sample: within 0.3 ms, where receive time minus latency
  // is off by up to 6 ms.
  EXPECT_LT(worst_after_1s, 300.0);
  EXPECT_GT(worst_receive, 5'000.0);
  EXPECT_EQ(map.restarts(), 0u);
}

TEST(ControllerClock, NothingBeforeTheFirstSample) {
  ControllerClockMap map(params());
  EXPECT_FALSE(map.stamp(1'000).has_value());
  EXPECT_FALSE(map.envelope().has_value());
}

TEST(ControllerClock, AControllerRestartStartsOver) {
  ControllerClockMap map(params());
  for (int k = 0; k < 100; ++k)
    map.observe(3'000'000 + 20'000 * k, kOffset + 3'000'000 + 20'000 * k + kLatency);
  // The controller restarted: its clock begins at 0 again, at host time kHost0 + 5 s.
  const Utime restart_host = kHost0 + 5'000'000;
  map.observe(20'000, restart_host + 20'000 + kLatency);
  EXPECT_EQ(map.restarts(), 1u);
  EXPECT_EQ(*map.stamp(20'000), restart_host + 20'000);
  // So does a clock that leaps ahead of the host's by more than a second.
  map.observe(20'000 + 5'000'000, restart_host + 40'000 + kLatency);
  EXPECT_EQ(map.restarts(), 2u);
  EXPECT_EQ(*map.stamp(5'020'000), restart_host + 40'000);
}

TEST(ControllerClock, FollowsAStepOfTheHostClockBothWays) {
  ControllerClockMap map(params());
  std::int64_t device = 3'000'000;
  Utime step = 0;
  const auto run = [&](int samples) {
    for (int k = 0; k < samples; ++k) {
      device += 20'000;
      map.observe(device, kOffset + device + step + kLatency + (k % 4) * 1'000);
    }
  };
  run(100);
  EXPECT_EQ(*map.stamp(device), kOffset + device);
  // The host clock jumps 5 s ahead (NTP): after confirm_us of late-looking samples, it follows.
  step = 5'000'000;
  run(50);
  EXPECT_EQ(map.restarts(), 1u);
  EXPECT_EQ(*map.stamp(device), kOffset + device + step);
  // And 7 s back: at once (the controller looks as if it leapt ahead: the window starts over).
  step = -2'000'000;
  run(1);
  EXPECT_EQ(*map.stamp(device), kOffset + device + step);
  EXPECT_EQ(map.restarts(), 2u);
}

TEST(ControllerClock, AStarvedReaderKeepsTheStamps) {
  ControllerClockMap map(params());
  std::int64_t device = 3'000'000;
  for (int k = 0; k < 100; ++k) {
    device += 20'000;
    map.observe(device, kOffset + device + kLatency);
  }
  // 2 s without CPU: 100 samples queued on the line, all read at once at the end.
  std::vector<std::int64_t> queued;
  for (int k = 0; k < 100; ++k) {
    device += 20'000;
    queued.push_back(device);
  }
  const Utime read_at = kOffset + device + kLatency + 500;
  for (const std::int64_t d : queued)
    map.observe(d, read_at);
  for (const std::int64_t d : queued)
    EXPECT_EQ(*map.stamp(d), kOffset + d);
  EXPECT_EQ(map.restarts(), 0u);
  // Another 2 s, its backlog taken in two reads 1 ms apart (the line's buffer was full): the
  // first read's samples are all late, its newest by 0.8 s; still no step, and the stamps hold.
  queued.clear();
  for (int k = 0; k < 100; ++k) {
    device += 20'000;
    queued.push_back(device);
  }
  const Utime first_read = kOffset + device + kLatency + 500;
  for (std::size_t k = 0; k < 60; ++k)
    map.observe(queued[k], first_read);
  // (The window's least delay is now the first backlog's newest, 0.5 ms.)
  for (std::size_t k = 0; k < 60; ++k)
    EXPECT_NEAR(static_cast<double>(*map.stamp(queued[k]) - (kOffset + queued[k])), 0.0, 600.0);
  for (std::size_t k = 60; k < queued.size(); ++k)
    map.observe(queued[k], first_read + 1'000);
  EXPECT_EQ(map.restarts(), 0u);
  EXPECT_NEAR(static_cast<double>(*map.stamp(device) - (kOffset + device)), 0.0, 600.0);
}

TEST(ControllerClock, FollowsADriftingControllerClock) {
  ControllerClockMap map(params());
  // The controller's crystal runs 100 ppm slow: 6 ms over a minute.
  for (int k = 0; k < 3'000; ++k) {
    const std::int64_t device = 3'000'000 + 20'000 * k;
    const Utime sampled = kOffset + 3'000'000 + static_cast<Utime>(20'000 * k * 1.0001);
    map.observe(device, sampled + kLatency + (k % 5) * 800);
    EXPECT_LE(std::abs(*map.stamp(device) - sampled), 250) << k;
  }
}

TEST(ControllerClock, ABacklogLongerThanTheWindowReadInTwoChunksKeepsTheStamps) {
  // Samples every 20 ms; the reader stalls for 3 s (longer than the 2 s window), then reads the
  // first 2.5 s of the backlog in one read and the rest 10 ms later. Every stamp is the sampling
  // time: the first chunk is not stamped late, the second does not jump back.
  ControllerClockMap map(params());
  const auto sampled = [](int k) { return kOffset + 3'000'000 + 20'000 * k; };
  Utime previous = 0;
  const auto read = [&](int from, int to, Utime received) {
    for (int k = from; k < to; ++k)
      map.observe(3'000'000 + 20'000 * k, received);
    for (int k = from; k < to; ++k) {
      const Utime stamp = *map.stamp(3'000'000 + 20'000 * k);
      EXPECT_EQ(stamp, sampled(k)) << k;
      EXPECT_GT(stamp, previous) << k;
      previous = stamp;
    }
  };
  for (int k = 0; k < 100; ++k)
    read(k, k + 1, sampled(k) + kLatency);
  // Stalled from sample 100 on, for 3 s (150 samples).
  read(100, 225, sampled(250) + kLatency);
  read(225, 251, sampled(250) + kLatency + 10'000);
  for (int k = 251; k < 400; ++k)
    read(k, k + 1, sampled(k) + kLatency);
  EXPECT_EQ(map.restarts(), 0u);
}

}  // namespace controller_clock_test
}  // namespace fieldline
