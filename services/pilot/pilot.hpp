// The scripted pilot's logic: follow this robot's trajectory from the scenario, steering with
// the pose it is given (SIM_WORLD truth or its own ROBOT_STATE), and produce normalised motion
// commands. Time in µs from whatever clock the caller uses; no bus.
#pragma once

#include <optional>

#include "common/geometry/geometry.hpp"
#include "common/robot/trajectory.hpp"
#include "common/scenario/scenario.hpp"
#include "common/time/clock.hpp"

namespace fieldline::pilot {

struct PilotConfig {
  // A pose older than this is not steered with: no command, the bridge stops the robot [s].
  double max_pose_age = 0.3;
  robot::FollowerGains gains;
};

class Pilot {
 public:
  // Throws std::invalid_argument when the scenario has no robot `robot_id`.
  Pilot(const scenario::Scenario& scenario, int robot_id, const robot::RobotParams& params,
        PilotConfig config = {});

  // The latest pose of the robot, valid at `utime`.
  void onPose(const geometry::Pose2& pose, Utime utime);
  // The command at `now`, or nothing when no fresh pose is known. The trajectory's clock
  // starts with the first pose.
  std::optional<robot::NormalizedCommand> command(Utime now);
  // The reference at `now` (after the first pose).
  std::optional<robot::TrajectorySample> reference(Utime now) const;

 private:
  robot::Trajectory trajectory_;
  robot::RobotParams params_;
  PilotConfig config_;
  std::optional<Utime> start_;
  std::optional<geometry::Pose2> pose_;
  Utime pose_utime_ = 0;
};

}  // namespace fieldline::pilot
