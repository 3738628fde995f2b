// The fusion structs with the rules that ship on (config/fusion/default.yaml, now the code's
// defaults) switched back off: the unit tests that test one mechanism of the ball filter, the
// delayed filter or the odometry layer in isolation start from these, so that another rule
// (a restart, a slip bound, a push) does not mask the one under test. The shipped combination
// is tested by the fusion scenario tests and fusion_config_test.
#pragma once

#include "services/fusion/ball_filter.hpp"
#include "services/fusion/history.hpp"
#include "services/fusion/odometry_layer.hpp"

namespace fieldline::fusion::test {

inline BallFilterParams bareBall() {
  BallFilterParams p;
  p.acceleration_density = 3.0;
  p.rest_acceleration_density = 3.0;  // one model
  p.stamp_sigma_s = 0.0;
  p.max_age_s = 1.0;
  p.sighting_floor_m = 0.0;
  p.invalid_after_outlier = false;
  p.pose_max_unconfirmed_s = 0.0;
  p.velocity_from_pair = false;
  p.fit_min_sightings = 2;
  p.unseen_range_m = 0.0;
  p.unseen_frames = 3;
  p.settle_s = 0.0;
  p.smooth_pose = false;
  return p;
}

inline FilterParams bareFilter() {
  FilterParams p;
  p.slip.max_m = 0.5;
  p.slip.max_rad = 0.5;
  p.slip.max_rad_gyro = 0.5;
  p.slip.max_speed = 0.0;
  p.slip.base_m = 0.0;
  p.slip.gyro_heading_chi2 = 0.0;
  p.contact.hold_us = 400'000;
  p.contact.position_density = 0.0;
  p.contact.heading_density = 0.0;
  p.contact.gyro_heading_density = 0.0;
  p.push.density = 0.0;
  p.push.free_decay_s = 0.1;
  p.push.max_speed = 0.0;
  p.push.unconfirmed_us = 0;
  return p;
}

inline OdometryNoise bareOdometry() {
  OdometryNoise p;
  p.wheel_slip_density = 0.02;
  p.translation_sigma_per_m = 0.02;
  p.gyro_heading_density = 0.0;
  return p;
}

}  // namespace fieldline::fusion::test
