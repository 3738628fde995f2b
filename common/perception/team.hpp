// What a robot knows of its team (TEAM_STATE without LCM): every robot's pose and ball in this
// robot's clock and field frame, the fused team ball and the link statistics. Written by
// teamcomm, read by behaviour, monitoring and the evaluation.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

namespace fieldline::perception {

inline constexpr int kTeamSize = 6;

struct TeammateState {
  // A packet from this robot arrived within the presence timeout (always true for ourselves
  // while our own ROBOT_STATE is fresh).
  bool present = false;
  // Pose in the field frame predicted to the picture's time, m and rad.
  double x = 0.0;
  double y = 0.0;
  double phi = 0.0;
  // Position standard deviation including the prediction, m.
  float sigma_xy = 0.0f;
  // Age of the pose estimate at the picture's time, µs.
  std::int64_t robot_age_us = 0;
  // The pose may be its symmetric twin through the centre spot: nothing has told the two apart
  // yet (its ROBOT_STATE.twin_ambiguous, carried by the team packet). Its ball may be mirrored.
  bool twin_ambiguous = false;
  // The robot reports a ball seen recently enough to use.
  bool ball_valid = false;
  // Its ball in the field frame predicted to the picture's time, m.
  double ball_x = 0.0;
  double ball_y = 0.0;
  // Age of its last ball observation at the picture's time, µs.
  std::int64_t ball_age_us = 0;
  // Its clock minus ours, µs, and the smallest round trip behind that estimate, µs (0: none).
  std::int64_t clock_offset_us = 0;
  std::int64_t round_trip_us = 0;
  // Packets accepted from it, and packets claiming to be from it that were refused.
  std::int32_t packets_received = 0;
  std::int32_t packets_rejected = 0;
};

struct TeamState {
  // Time the picture refers to, µs since the epoch on this robot's clock.
  std::int64_t utime = 0;
  // Index i is robot i+1.
  std::array<TeammateState, kTeamSize> robots{};
  bool team_ball_valid = false;
  // Field frame, m and m/s.
  double team_ball_x = 0.0;
  double team_ball_y = 0.0;
  double team_ball_vx = 0.0;
  double team_ball_vy = 0.0;
  Eigen::Matrix2d team_ball_covariance = Eigen::Matrix2d::Zero();
};

}  // namespace fieldline::perception
