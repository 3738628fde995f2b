#include "services/pilot/pilot.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

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

void Pilot::onPose(const geometry::Pose2& pose, Utime utime, PoseQuality quality,
                   const std::string& why) {
  if (!geometry::isFinite(pose)) return;
  // Late: keep the newer pose. The same stamp again is fusion's state corrected by a camera frame
  // (published right after the correction): take it.
  if (pose_ && utime < pose_utime_) return;
  pose_ = pose;
  pose_utime_ = utime;
  pose_quality_ = quality;
  pose_problem_ = why;
}

double Pilot::clockStep(Utime now) const {
  if (!driving_) return 0.0;
  const double elapsed = std::max(0.0, static_cast<double>(now - last_drive_) * 1e-6);
  return std::min(elapsed, config_.max_clock_step) * clock_rate_;
}

std::optional<robot::TrajectorySample> Pilot::reference(Utime now) const {
  if (!pose_) return std::nullopt;
  return trajectory_.at(trajectory_time_ + clockStep(now));
}

bool Pilot::nearerThanItsTwin(Utime now) const {
  const geometry::Pose2 ref = trajectory_.at(trajectory_time_ + clockStep(now)).pose;
  const auto distance = [&](const geometry::Pose2& p) {
    return std::hypot(p.x - ref.x, p.y - ref.y) + std::abs(geometry::angleDiff(p.phi, ref.phi));
  };
  const geometry::Pose2 twin{-pose_->x, -pose_->y,
                             geometry::normalizeAngle(pose_->phi + std::numbers::pi)};
  return distance(*pose_) + config_.twin_margin < distance(twin);
}

std::optional<robot::NormalizedCommand> Pilot::command(Utime now) {
  const double age = static_cast<double>(now - pose_utime_) * 1e-6;
  if (!pose_) {
    hold_reason_ = "waiting for the first pose";
  } else if (age > config_.max_pose_age) {
    hold_reason_ = fmt::format("the newest pose is {:.1f} s old", age);
  } else if (pose_quality_ == PoseQuality::kUnusable) {
    hold_reason_ = "the pose is " + pose_problem_;
  } else if (pose_quality_ == PoseQuality::kTwinAmbiguous && !nearerThanItsTwin(now)) {
    hold_reason_ = "the pose is twin-ambiguous and the trajectory does not tell it from its twin";
  } else {
    hold_reason_.clear();
  }
  if (!hold_reason_.empty()) {
    // The trajectory waits: when the pilot drives again it goes on from where it stopped.
    driving_ = false;
    return std::nullopt;
  }
  trajectory_time_ += clockStep(now);
  last_drive_ = now;
  driving_ = true;
  robot::TrajectorySample reference = trajectory_.at(trajectory_time_);
  // Behind the reference: its clock slows (to a stop at max_lag) and its velocity with it, so
  // the robot closes the gap at about its scripted speed instead of sprinting after it.
  const double lag = (reference.pose.position() - pose_->position()).norm();
  clock_rate_ = std::clamp(
      1.0 - (lag - config_.lag_start) / std::max(1e-6, config_.max_lag - config_.lag_start), 0.0,
      1.0);
  const double scripted_speed = reference.velocity.norm();
  reference.velocity *= clock_rate_;
  reference.omega *= clock_rate_;
  robot::NormalizedCommand cmd = robot::followTrajectory(reference, *pose_, params_, config_.gains);
  const double limit = std::max(config_.min_speed, config_.max_speed_factor * scripted_speed);
  const double speed = std::hypot(cmd.vx, cmd.vy) * params_.max_speed;
  if (speed > limit) {
    cmd.vx *= limit / speed;
    cmd.vy *= limit / speed;
  }
  return cmd;
}

}  // namespace fieldline::pilot
