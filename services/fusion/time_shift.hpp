// The time shift between odometry and vision (seed 4.7.2): while the robot turns with the ball
// lying still, odometry's rotation rate and the rate at which the ball's bearing turns the other
// way are the same signal; the shift that correlates them best is how much later vision's stamps
// are than odometry's. With correctly configured latencies it is zero.
#pragma once

#include <optional>
#include <vector>

#include "common/time/clock.hpp"

namespace fieldline::fusion {

struct RateSample {
  Utime utime = 0;
  // rad/s CCW.
  double rate = 0.0;
};

// Rotation rates from successive ball bearings (robot frame points, one per frame): minus the
// bearing's rate, at the middle of each pair of frames. Frames further apart than max_gap_us
// or with the ball nearer than min_range_m give nothing.
struct BallBearing {
  Utime utime = 0;
  double x = 0.0;
  double y = 0.0;
};
std::vector<RateSample> ratesFromBearings(const std::vector<BallBearing>& sightings,
                                          Utime max_gap_us = 100'000, double min_range_m = 0.5);

struct TimeShift {
  // Vision's stamps are this much later than odometry's for the same motion, µs.
  Utime shift_us = 0;
  // Pearson correlation at that shift, -1..1.
  double correlation = 0.0;
  // Grid points compared.
  int samples = 0;
};

// Searches shifts in [-max_shift_us, max_shift_us] in steps of step_us. Empty when the signals
// overlap too little or do not vary.
std::optional<TimeShift> estimateTimeShift(const std::vector<RateSample>& odometry,
                                           const std::vector<RateSample>& vision,
                                           Utime max_shift_us = 300'000, Utime step_us = 2'000);

}  // namespace fieldline::fusion
