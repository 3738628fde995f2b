// The odometry-vision time shift from a robot turning back and forth next to a ball lying still:
// the bearing-rate signal stamped 45 ms late is found 45 ms late.
#include "services/fusion/time_shift.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace fieldline::fusion {
namespace time_shift_test {

TEST(TimeShift, FindsTheDelayOfTheBallBearing) {
  constexpr Utime kStart = 1'800'000'000'000'000;
  constexpr Utime kLate = 45'000;
  auto heading = [](double t) { return 0.8 * std::sin(1.3 * t) + 0.4 * std::sin(3.1 * t); };
  auto omega = [](double t) {
    return 0.8 * 1.3 * std::cos(1.3 * t) + 0.4 * 3.1 * std::cos(3.1 * t);
  };
  std::vector<RateSample> odometry;
  for (int k = 0; k < 500; ++k) {
    const double t = k * 0.02;
    odometry.push_back({kStart + k * 20'000, omega(t)});
  }
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::vector<BallBearing> ball;
  for (int k = 0; k < 300; ++k) {
    const double t = k * 0.0333;
    // A ball 2 m away at field bearing 0.3: in the robot frame at heading(t).
    const double b = 0.3 - heading(t) + noise(rng);
    ball.push_back(
        {kStart + static_cast<Utime>(t * 1e6) + kLate, 2.0 * std::cos(b), 2.0 * std::sin(b)});
  }
  const auto vision = ratesFromBearings(ball);
  ASSERT_GT(vision.size(), 250u);
  const auto shift = estimateTimeShift(odometry, vision);
  ASSERT_TRUE(shift.has_value());
  EXPECT_NEAR(static_cast<double>(shift->shift_us), static_cast<double>(kLate), 6'000.0);
  EXPECT_GT(shift->correlation, 0.9);
  // No overlap, no answer.
  EXPECT_FALSE(estimateTimeShift(odometry, {}).has_value());
}

}  // namespace time_shift_test
}  // namespace fieldline::fusion
