#include "services/pilot/pilot_node.hpp"

#include <stdexcept>

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
  if (options_.steer == SteerBy::kTruth) {
    node_.subscribe(
        bus::channels::kSimWorld, [this](const world_state_t& w) { onWorld(w); }, options_.sim_bus);
  } else {
    node_.subscribe(bus::channels::kRobotState, [this](const robot_state_t& s) { onState(s); });
  }
  node_.every(static_cast<Utime>(1e6 / options_.rate), [this] { sendCommand(); });
  node_.every(kMicrosPerSecond, [this] {
    if (const auto ref = pilot_.reference(node_.now())) {
      node_.setMetric("reference_speed_mps", ref->velocity.norm());
    }
  });
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
  // Fusion does not know where the robot is yet: nothing to steer with.
  if (estimate.status == perception::LocalizationStatus::kUnknown) return;
  pilot_.onPose(estimate.pose, estimate.utime);
}

void PilotNode::sendCommand() {
  const Utime now = node_.now();
  const auto cmd = pilot_.command(now);
  if (!cmd) {
    // No fresh pose: say nothing, so the bridge lets the robot stop.
    if (waiting_++ % static_cast<std::int64_t>(options_.rate * 5) == 0) {
      spdlog::info("waiting for a pose ({})",
                   options_.steer == SteerBy::kTruth ? "SIM_WORLD" : "ROBOT_STATE");
    }
    return;
  }
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
  spdlog::info("holding still (no --scenario): no MOTION_COMMAND is sent");
  node.setMetric("holding", 1.0);
}

}  // namespace fieldline::pilot
