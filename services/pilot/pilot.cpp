#include "services/pilot/pilot.hpp"

#include <stdexcept>

namespace fieldline::pilot {
namespace {

const scenario::RobotSpec& robotSpec(const scenario::Scenario& scenario, int id) {
  const auto* spec = scenario.robotById(id);
  if (!spec) {
    throw std::invalid_argument("scenario " + scenario.name + " has no robot " +
                                std::to_string(id));
  }
  return *spec;
}

}  // namespace

Pilot::Pilot(const scenario::Scenario& scenario, int robot_id, const robot::RobotParams& params,
             PilotConfig config)
    : trajectory_(robotSpec(scenario, robot_id).trajectory, robotSpec(scenario, robot_id).start),
      params_(params),
      config_(config) {}

void Pilot::onPose(const geometry::Pose2& pose, Utime utime) {
  if (!geometry::isFinite(pose)) return;
  if (pose_ && utime <= pose_utime_) return;  // late or repeated: keep the newer pose
  if (!start_) start_ = utime;
  pose_ = pose;
  pose_utime_ = utime;
}

std::optional<robot::TrajectorySample> Pilot::reference(Utime now) const {
  if (!start_) return std::nullopt;
  return trajectory_.at(static_cast<double>(now - *start_) * 1e-6);
}

std::optional<robot::NormalizedCommand> Pilot::command(Utime now) {
  if (!pose_ || static_cast<double>(now - pose_utime_) * 1e-6 > config_.max_pose_age) {
    return std::nullopt;
  }
  return robot::followTrajectory(*reference(now), *pose_, params_, config_.gains);
}

}  // namespace fieldline::pilot
