#include <gtest/gtest.h>

#include "common/time/clock.hpp"

namespace fieldline {
namespace {

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

}  // namespace
}  // namespace fieldline
