#include <gtest/gtest.h>

#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline {
namespace clock_test {

TEST(SimulatedClock, MovesOnlyWhenTold) {
  SimulatedClock clock(1000);
  EXPECT_EQ(clock.now(), 1000);
  EXPECT_EQ(clock.now(), 1000);
  clock.advance(250);
  EXPECT_EQ(clock.now(), 1250);
  clock.set(42);
  EXPECT_EQ(clock.now(), 42);
}

TEST(SimulatedClock, MonotonicTimeIgnoresStepsBack) {
  SimulatedClock clock(1'000'000);
  const Utime m0 = clock.monotonicNow();
  clock.advance(500);
  EXPECT_EQ(clock.monotonicNow() - m0, 500);
  // A wall step back by an hour elapses nothing; forward steps by step() neither.
  clock.step(-3'600'000'000);
  EXPECT_EQ(clock.now(), 1'000'500 - 3'600'000'000);
  EXPECT_EQ(clock.monotonicNow() - m0, 500);
  clock.step(100);
  EXPECT_EQ(clock.monotonicNow() - m0, 500);
  // set() forward is elapsed time (a replay moving to the next message), backward is not.
  clock.set(clock.now() + 2000);
  EXPECT_EQ(clock.monotonicNow() - m0, 2500);
  clock.set(clock.now() - 5000);
  EXPECT_EQ(clock.monotonicNow() - m0, 2500);
}

TEST(SystemClock, IsEpochMicrosecondsAndMonotonicEnough) {
  SystemClock clock;
  const Utime a = clock.now();
  // After 2020-01-01 and before 2100: microseconds, not seconds or nanoseconds.
  EXPECT_GT(a, 1'577'836'800'000'000);
  EXPECT_LT(a, 4'102'444'800'000'000);
  EXPECT_GE(clock.now(), a);
  const Utime m = clock.monotonicNow();
  EXPECT_GE(clock.monotonicNow(), m);
}

}  // namespace clock_test
}  // namespace fieldline

namespace fieldline {
namespace clock_test {

TEST(RobotClock, RunsOffTheTruthAndConvertsBack) {
  SimulatedClock truth(1'700'000'000'000'000);
  const ClockError error{437'000, 50.0, truth.now()};
  OffsetClock robot(truth, error);
  EXPECT_EQ(robot.now(), truth.now() + 437'000);
  // 100 s later the drift has added 5 ms.
  truth.advance(100 * kMicrosPerSecond);
  EXPECT_EQ(robot.now(), truth.now() + 437'000 + 5'000);
  // Back to the truth to the rounding of one µs.
  EXPECT_NEAR(static_cast<double>(robot.toTruth(robot.now()) - truth.now()), 0.0, 1.0);
  EXPECT_EQ(robot.fromTruth(truth.now()), robot.now());
  // Round trips over an hour either side of the reference and with a negative drift.
  const ClockError slow{-312'000, -40.0, 1'700'000'000'000'000};
  for (Utime t = 1'700'000'000'000'000 - 3'600'000'000; t <= 1'700'000'000'000'000 + 3'600'000'000;
       t += 123'456'789) {
    EXPECT_NEAR(static_cast<double>(ownToTruth(slow, truthToOwn(slow, t)) - t), 0.0, 1.0);
    EXPECT_NEAR(static_cast<double>(ownToTruth(error, truthToOwn(error, t)) - t), 0.0, 1.0);
  }
  // Elapsed time is the base's.
  EXPECT_EQ(robot.monotonicNow(), truth.monotonicNow());
}

TEST(RobotClock, WithoutErrorIsTheSystemClock) {
  const RobotClock clock;
  SystemClock system;
  const Utime a = system.now();
  const Utime b = clock.now();
  const Utime c = system.now();
  EXPECT_LE(a, b);
  EXPECT_LE(b, c);
  EXPECT_EQ(clock.toTruth(b), b);
  const RobotClock off(ClockError{-250'000, 0.0, 0});
  const Utime d = off.now();
  EXPECT_NEAR(static_cast<double>(off.toTruth(d) - system.now()), 0.0, 50'000.0);
  EXPECT_EQ(off.toTruth(d), d + 250'000);
}

TEST(RobotClock, ErrorFromTheEnvironment) {
  unsetenv(kClockOffsetVariable);
  unsetenv(kClockDriftVariable);
  unsetenv(kClockReferenceVariable);
  EXPECT_FALSE(clockErrorFromEnvironment().has_value());
  setenv(kClockOffsetVariable, "-447000", 1);
  setenv(kClockDriftVariable, "-21", 1);
  EXPECT_THROW(clockErrorFromEnvironment(), std::invalid_argument);  // drift without reference
  setenv(kClockReferenceVariable, "1700000000000000", 1);
  const auto e = clockErrorFromEnvironment();
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->offset_us, -447'000);
  EXPECT_EQ(e->drift_ppm, -21.0);
  EXPECT_EQ(e->reference_us, 1'700'000'000'000'000);
  setenv(kClockDriftVariable, "1500", 1);
  EXPECT_THROW(clockErrorFromEnvironment(), std::invalid_argument);
  setenv(kClockDriftVariable, "12ppm", 1);
  EXPECT_THROW(clockErrorFromEnvironment(), std::invalid_argument);
  unsetenv(kClockOffsetVariable);
  unsetenv(kClockDriftVariable);
  unsetenv(kClockReferenceVariable);
}

}  // namespace clock_test
}  // namespace fieldline
