#include "services/pilot/pilot_node.hpp"

#include <stdexcept>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/msg/estimates.hpp"
#include "common/msg/motion_command.hpp"
#include "common/msg/world_state.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline::pilot {

PilotNode::PilotNode(bus::Node& node, Pilot pilot, PilotNodeOptions options)
    : node_(node), pilot_(std::move(pilot)), options_(options) {
  if (!(options_.rate > 0.0) || !(options_.command_lifetime > 0.0)) {
    throw std::invalid_argument("pilot rate and command lifetime must be positive");
  }
  // The pose is needed at the next command only: its messages do not wake the pilot, they are
  // handled just before the command timer (issue 32: half the wake-ups).
  if (options_.steer == SteerBy::kTruth) {
    node_.subscribeDeferred(
        bus::channels::kSimWorld, [this](const world_state_t& w) { onWorld(w); }, options_.sim_bus);
  } else {
    node_.subscribeDeferred(bus::channels::kRobotState,
                            [this](const robot_state_t& s) { onState(s); });
  }
  node_.every(static_cast<Utime>(1e6 / options_.rate), [this] { sendCommand(); });
  node_.every(kMicrosPerSecond, [this] {
    if (const auto ref = pilot_.reference(node_.now())) {
      node_.setMetric("reference_speed_mps", ref->velocity.norm());
    }
    node_.setMetric("trajectory_time_s", pilot_.trajectoryTime());
  });
  // The pose it steers with must flow (at half its rate, as every required input).
  if (options_.steer == SteerBy::kTruth) {
    node_.requireInput(
        bus::channels::kSimWorld,
        bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kSimWorld.name));
  } else {
    node_.requireInput(
        bus::channels::kRobotState,
        bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kRobotState.name));
  }
  node_.declareIo(pilotIo(options_.steer));
}

bus::ProcessIo pilotIo(std::optional<SteerBy> driving) {
  bus::ProcessIo io("pilot");
  if (!driving) return io;
  if (*driving == SteerBy::kTruth) {
    io.reads(bus::channels::kSimWorld);
  } else {
    io.reads(bus::channels::kRobotState);
  }
  return io.writes(bus::channels::kMotionCommand);
}

void PilotNode::onWorld(const world_state_t& w) {
  const auto truth = msg::fromMessage(w);
  // The truth's time converted to the robot's clock, on which the pilot runs.
  if (const auto* robot = truth.robot(node_.robotId())) {
    pilot_.onPose(robot->pose, fromTruth(node_.clock(), truth.utime));
  }
}

void PilotNode::onState(const robot_state_t& s) {
  const auto estimate = msg::fromMessage(s);
  using perception::LocalizationStatus;
  switch (estimate.status) {
    case LocalizationStatus::kTracking:
      pilot_.onPose(estimate.pose, estimate.utime,
                    estimate.twin_ambiguous ? PoseQuality::kTwinAmbiguous : PoseQuality::kUsable);
      return;
    case LocalizationStatus::kSearching:
      pilot_.onPose(estimate.pose, estimate.utime, PoseQuality::kUnusable,
                    "SEARCHING (a guess of fusion's relocalization)");
      return;
    case LocalizationStatus::kOdometryOnly:
      pilot_.onPose(estimate.pose, estimate.utime, PoseQuality::kUnusable,
                    "ODOMETRY_ONLY (no vision correction lately)");
      return;
    case LocalizationStatus::kUnknown:
      pilot_.onPose(estimate.pose, estimate.utime, PoseQuality::kUnusable, "UNKNOWN");
      return;
  }
}

void PilotNode::sendCommand() {
  const Utime now = node_.now();
  const auto cmd = pilot_.command(now);
  if (!cmd) {
    // No pose to steer with: say nothing, so the bridge lets the robot stop.
    if (holding_since_ < 0) holding_since_ = now;
    const std::string source = options_.steer == SteerBy::kTruth ? "SIM_WORLD" : "ROBOT_STATE";
    if (waiting_++ % static_cast<std::int64_t>(options_.rate * 5) == 0) {
      spdlog::info("holding: {} ({})", pilot_.holdReason(), source);
    }
    // A pilot that should drive and cannot says so (a short wait, as at start-up, is no warning).
    if (now - holding_since_ >= kHoldWarnAfterUs) {
      node_.status().setWarning(
          "holding", fmt::format("holding for {:.1f} s, not driving its trajectory: {} ({})",
                                 static_cast<double>(now - holding_since_) * 1e-6,
                                 pilot_.holdReason(), source));
    }
    node_.setMetric("holding", 1.0);
    return;
  }
  holding_since_ = -1;
  waiting_ = 0;
  node_.status().setWarning("holding", "");
  node_.setMetric("holding", 0.0);
  perception::MotionCommand command;
  command.utime = now;
  command.vx = cmd->vx;
  command.vy = cmd->vy;
  command.omega = cmd->omega;
  command.deadline_utime = now + static_cast<Utime>(options_.command_lifetime * 1e6);
  command.source = perception::CommandSource::kPilot;
  msg::toMessage(command, command_);
  if (node_.publish(bus::channels::kMotionCommand, command_)) ++commands_sent_;
}

void holdStill(bus::Node& node) {
  node.declareIo(pilotIo(std::nullopt));
  spdlog::info("holding still (no --scenario): no MOTION_COMMAND is sent");
  node.setMetric("holding", 1.0);
}

}  // namespace fieldline::pilot
