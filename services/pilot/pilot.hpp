// The scripted pilot's logic: follow this robot's trajectory from the scenario, steering with
// the pose it is given (SIM_WORLD truth or its own ROBOT_STATE), and produce normalised motion
// commands. Time in µs from whatever clock the caller uses; no bus.
//
// It never steers on a guess and never sprints (issue 34, red-team finding 4):
// - a pose is steered with only when fusion is TRACKING (the truth always is). Otherwise the
//   pilot holds: no command, so the bridge stops the robot, and holdReason() says why. (It used to
//   turn at full rate towards a SEARCHING guess at the field's twin, 7.35 m away.) A
//   twin-ambiguous pose (fusion cannot tell it from its point-symmetric twin) is steered with
//   only when the pilot's own reference tells them apart by twin_margin: the robot is where its
//   trajectory has it, not at the twin (true at a match's start, where every robot begins
//   ambiguous until its teammates see the ball; not after fusion restarts in the other half).
// - the trajectory has its own clock, which runs only while the pilot drives, at most
//   max_clock_step per command (a stall of the machine or of the pose does not move the
//   reference on), and slower as the robot falls behind (stopped at max_lag): after a stall the
//   trajectory waits for the robot instead of the robot sprinting at twice its speed after it.
// - the translation never exceeds max_speed_factor times the reference's speed (at least
//   min_speed): catching up is done at about the scripted speed.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "common/geometry/geometry.hpp"
#include "common/robot/trajectory.hpp"
#include "common/scenario/scenario.hpp"
#include "common/time/clock.hpp"

namespace fieldline::pilot {

struct PilotConfig {
  // A pose older than this is not steered with: no command, the bridge stops the robot [s].
  double max_pose_age = 0.3;
  robot::FollowerGains gains;
  // The trajectory clock moves at most this much per command, whatever time passed [s].
  double max_clock_step = 0.1;
  // Behind the reference by more than lag_start the trajectory clock slows down, linearly to a
  // stop at max_lag [m].
  double lag_start = 0.2;
  double max_lag = 0.5;
  // Translation speed limit: this factor times the reference's own speed, at least min_speed.
  double max_speed_factor = 1.25;
  double min_speed = 0.3;  // [m/s]
  // A twin-ambiguous pose is used only when it is this much nearer the reference than its twin
  // is (distance in m plus heading difference in rad, weighted 1 m/rad).
  double twin_margin = 1.0;
};

enum class PoseQuality : std::int8_t {
  // Steer with it (the truth, or fusion TRACKING).
  kUsable,
  // TRACKING, but it may be its twin: steered with only if the reference tells them apart.
  kTwinAmbiguous,
  // Not to steer with (fusion SEARCHING, ODOMETRY_ONLY).
  kUnusable,
};

class Pilot {
 public:
  // Throws std::invalid_argument when the scenario has no robot `robot_id`.
  Pilot(const scenario::Scenario& scenario, int robot_id, const robot::RobotParams& params,
        PilotConfig config = {});

  // The latest pose of the robot, valid at `utime`, and whether to steer with it; `why` says
  // what an unusable one was, for holdReason().
  void onPose(const geometry::Pose2& pose, Utime utime, PoseQuality quality = PoseQuality::kUsable,
              const std::string& why = {});
  // The command at `now`, or nothing when no fresh usable pose is known (holdReason() says why).
  // Advances the trajectory clock while it drives.
  std::optional<robot::NormalizedCommand> command(Utime now);
  // Why the last command() gave nothing; empty while driving.
  const std::string& holdReason() const { return hold_reason_; }
  // The reference at `now` (after the first drive).
  std::optional<robot::TrajectorySample> reference(Utime now) const;
  // The trajectory clock [s]: how far along its trajectory the robot is meant to be.
  double trajectoryTime() const { return trajectory_time_; }

 private:
  double clockStep(Utime now) const;
  // The pose is nearer the reference than its point-symmetric twin is, by twin_margin.
  bool nearerThanItsTwin(Utime now) const;

  robot::Trajectory trajectory_;
  robot::RobotParams params_;
  PilotConfig config_;
  std::optional<geometry::Pose2> pose_;
  Utime pose_utime_ = 0;
  PoseQuality pose_quality_ = PoseQuality::kUnusable;
  std::string pose_problem_;
  // Trajectory clock and the time of the last command that advanced it (0: not driving yet).
  double trajectory_time_ = 0.0;
  Utime last_drive_ = 0;
  bool driving_ = false;
  double clock_rate_ = 1.0;
  std::string hold_reason_ = "waiting for the first pose";
};

}  // namespace fieldline::pilot
