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

TEST(SystemClock, IsEpochMicrosecondsAndMonotonicEnough) {
  SystemClock clock;
  const Utime a = clock.now();
  // After 2020-01-01 and before 2100: microseconds, not seconds or nanoseconds.
  EXPECT_GT(a, 1'577'836'800'000'000);
  EXPECT_LT(a, 4'102'444'800'000'000);
  EXPECT_GE(clock.now(), a);
}

}  // namespace
}  // namespace fieldline
