#include <gtest/gtest.h>

#include "tools/launch/backoff.hpp"

namespace fieldline::launch {
namespace backoff_test {

TEST(RestartBackoff, DoublesFromHalfASecondUpToTenSeconds) {
  RestartBackoff b;  // 0.5 s doubling to 10 s, stable after 60 s
  const double expected[] = {0.5, 1.0, 2.0, 4.0, 8.0, 10.0, 10.0, 10.0};
  for (double e : expected)
    EXPECT_DOUBLE_EQ(b.delayAfterExit(0.1), e);
  EXPECT_EQ(b.consecutiveFailures(), 8);
}

TEST(RestartBackoff, AStableRunResetsTheDelay) {
  RestartBackoff b;
  for (int i = 0; i < 5; ++i)
    b.delayAfterExit(1.0);
  // 59.9 s is not stable: keeps growing (the sixth crash would be 16 s, capped at 10).
  EXPECT_DOUBLE_EQ(b.delayAfterExit(59.9), 10.0);
  // 60 s is: back to the first delay, then doubling again.
  EXPECT_DOUBLE_EQ(b.delayAfterExit(60.0), 0.5);
  EXPECT_EQ(b.consecutiveFailures(), 1);
  EXPECT_DOUBLE_EQ(b.delayAfterExit(3.0), 1.0);
}

TEST(RestartBackoff, CustomParameters) {
  RestartBackoff b(BackoffParams{.initial_s = 0.2, .max_s = 1.0, .stable_s = 5.0});
  EXPECT_DOUBLE_EQ(b.delayAfterExit(0.0), 0.2);
  EXPECT_DOUBLE_EQ(b.delayAfterExit(0.0), 0.4);
  EXPECT_DOUBLE_EQ(b.delayAfterExit(0.0), 0.8);
  EXPECT_DOUBLE_EQ(b.delayAfterExit(0.0), 1.0);
  EXPECT_DOUBLE_EQ(b.delayAfterExit(5.0), 0.2);
}

TEST(RestartBackoff, StaysFiniteInALongCrashLoop) {
  RestartBackoff b;
  double last = 0;
  for (int i = 0; i < 5000; ++i)
    last = b.delayAfterExit(0.0);
  EXPECT_DOUBLE_EQ(last, 10.0);
}

}  // namespace backoff_test
}  // namespace fieldline::launch
