// The robots' clocks against a log's time (tools/recording/clock_model.hpp): fitted from
// synthetic traffic with a known clock, and from the "before" fixture, recorded by lcm-logger
// with robot 1's clock 312 ms ahead (tests/data/recordings/main_9085e4b).
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/config/config.hpp"
#include "tools/recording/clock_model.hpp"

namespace fieldline::recording {
namespace clock_model_test {

const std::string kBefore = config::projectRoot() + "/tests/data/recordings/main_9085e4b";

// Messages published at 200 Hz by a robot whose clock is `truth` + offset + drift over
// `seconds`, received after a delay of 0.1 ms plus an exponential tail (mean 2 ms) with a
// few 50-200 ms stalls of the recorder.
std::vector<StampSample> traffic(const ClockError& clock, double seconds, unsigned seed) {
  std::mt19937 random(seed);
  std::exponential_distribution<double> tail(1.0 / 2000.0);
  std::uniform_real_distribution<double> stall(50'000.0, 200'000.0);
  std::vector<StampSample> samples;
  const Utime start = clock.reference_us;
  for (Utime t = start; t < start + static_cast<Utime>(seconds * 1e6); t += 5'000) {
    double delay = 100.0 + tail(random);
    if (random() % 500 == 0) delay += stall(random);
    samples.push_back({t + static_cast<Utime>(delay), truthToOwn(clock, t)});
  }
  return samples;
}

TEST(ClockModel, FitsTheOffsetOfAShortLogAndTheDriftOfALongOne) {
  const ClockError clock{312'000, 38.0, 1'796'541'078'000'000};
  // 30 s: too short for the drift (0 is reported), the offset within the drift's 1.1 ms.
  const auto short_fit = fitClock(traffic(clock, 30.0, 1));
  ASSERT_TRUE(short_fit);
  EXPECT_EQ(short_fit->source, ClockSource::kEstimated);
  EXPECT_EQ(short_fit->error.drift_ppm, 0.0);
  EXPECT_NEAR(short_fit->error.offset_us, 312'000 + 38.0 * 15.0, 1'200);
  // 10 minutes: both, and every reading of the clock within 0.5 ms.
  const auto long_fit = fitClock(traffic(clock, 600.0, 2));
  ASSERT_TRUE(long_fit);
  EXPECT_NEAR(long_fit->error.drift_ppm, 38.0, 2.0);
  for (const Utime t :
       {clock.reference_us, clock.reference_us + 300'000'000, clock.reference_us + 599'000'000})
    EXPECT_NEAR(static_cast<double>(long_fit->ownAt(t) - truthToOwn(clock, t)), 0.0, 500.0);
  // The delay it reports is the traffic's (0.1 ms + the tail), not the stalls'.
  EXPECT_GT(long_fit->delay_p50_ms, 0.5);
  EXPECT_LT(long_fit->delay_p50_ms, 3.0);
  EXPECT_EQ(long_fit->samples, 120'000);
  EXPECT_NE(long_fit->describe().find("estimated from 120000 messages"), std::string::npos);
}

TEST(ClockModel, ANegativeOffsetAndTooFewMessages) {
  const ClockError clock{-447'000, -21.0, 1'796'541'078'000'000};
  const auto fit = fitClock(traffic(clock, 20.0, 3));
  ASSERT_TRUE(fit);
  EXPECT_NEAR(fit->error.offset_us, -447'000, 1'000);
  EXPECT_FALSE(fitClock({}));
  // Four messages fill no window.
  EXPECT_FALSE(fitClock({{1, 2}, {3, 4}, {5, 6}, {7, 8}}));
}

TEST(ClockModel, ConvertsBothWays) {
  RobotClockModel model;
  model.error = {312'000, 38.0, 1'000'000'000'000'000};
  for (const Utime log : {Utime{1'000'000'000'000'000}, Utime{1'000'000'600'000'000}})
    EXPECT_NEAR(static_cast<double>(model.logAt(model.ownAt(log)) - log), 0.0, 1.0);
  EXPECT_EQ(model.ownAt(1'000'000'000'000'000), 1'000'000'000'312'000);
}

TEST(ClockModel, PeeksTheHeaderOfEncodedBytes) {
  header_t h{};
  h.utime = 1'700'000'000'000'123;
  h.utime_published = h.utime + 60'000;
  h.seq = 7;
  h.robot_id = 3;
  h.publisher_id = 99;
  // Any fieldline message: the fingerprint, then the header.
  std::vector<std::uint8_t> bytes(8 + static_cast<std::size_t>(h._getEncodedSizeNoHash()) + 4);
  ASSERT_GT(h._encodeNoHash(bytes.data(), 8, static_cast<int>(bytes.size()) - 8), 0);
  const auto peeked = peekHeader(bytes.data(), static_cast<int>(bytes.size()));
  ASSERT_TRUE(peeked);
  EXPECT_EQ(peeked->utime_published, h.utime_published);
  EXPECT_EQ(peeked->robot_id, 3);
  EXPECT_FALSE(peekHeader(bytes.data(), 20));
  EXPECT_FALSE(peekHeader(nullptr, 0));
}

TEST(ClockModel, FindsRobotOnesClockInALogThatDoesNotCarryIt) {
  // lcm-logger's recording of robot 1's bus: launched with offset 0.312 s, drift 38 ppm from the
  // launch, 5 s long (so the drift adds at most 0.2 ms).
  const auto robot = estimateClocks(kBefore + "/robot1.lcm");
  ASSERT_EQ(robot.count(1), 1u);
  EXPECT_NEAR(robot.at(1).error.offset_us, 312'000, 1'000) << robot.at(1).describe();
  EXPECT_GT(robot.at(1).samples, 1000);
  // The simulator's bus: the simulator keeps the true time, which is the log's.
  const auto sim = estimateClocks(kBefore + "/sim.lcm");
  ASSERT_EQ(sim.count(0), 1u);
  EXPECT_NEAR(sim.at(0).error.offset_us, 0, 1'000);
}

}  // namespace clock_model_test
}  // namespace fieldline::recording
