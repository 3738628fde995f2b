// What fusion estimates (ROBOT_STATE, BALL_STATE without LCM), and what a ball looks like in one
// frame (VISION_BALL): read by fusion, teamcomm, the pilot and the evaluation tools.
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "common/geometry/geometry.hpp"

namespace fieldline::perception {

// Values equal robot_state_t's STATUS_ constants (checked at compile time in common/msg).
enum class LocalizationStatus : std::int8_t {
  kUnknown = 0,
  kSearching = 1,
  kTracking = 2,
  kOdometryOnly = 3,
};

struct RobotEstimate {
  // Time the estimate refers to, µs since the epoch on this robot's clock.
  std::int64_t utime = 0;
  // Pose in the field frame.
  geometry::Pose2 pose;
  // Velocity in the field frame, m/s, and angular velocity, rad/s CCW.
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;
  // Covariance of (x, y, phi).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  LocalizationStatus status = LocalizationStatus::kUnknown;
  // Time since the last accepted vision correction, µs.
  std::int64_t since_vision_us = 0;
  // The pose may be its point-symmetric twin: nothing told them apart yet.
  bool twin_ambiguous = false;
};

struct BallEstimate {
  std::int64_t utime = 0;
  // True when the ball was seen recently enough for the estimate to mean something.
  bool valid = false;
  // Field frame, m and m/s.
  double x = 0.0;
  double y = 0.0;
  double vx = 0.0;
  double vy = 0.0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  // Time of the last observation used, µs since the epoch.
  std::int64_t last_seen_utime = 0;
};

// The ball in one camera frame (robot frame), at the frame's exposure time.
struct BallSighting {
  std::int64_t utime = 0;
  bool visible = false;
  // Image position, px.
  double u = 0.0;
  double v = 0.0;
  // Floor position under the ball centre in the robot frame, m.
  double x = 0.0;
  double y = 0.0;
  // Standard deviations along and across the viewing ray, m.
  double sigma_radial = 0.0;
  double sigma_tangential = 0.0;
  int cells = 0;
  double confidence = 0.0;
};

}  // namespace fieldline::perception
