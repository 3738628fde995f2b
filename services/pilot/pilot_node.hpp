// The pilot process's bus side: the pose to steer with in (SIM_WORLD ground truth from the
// simulator's bus, or the robot's own ROBOT_STATE), MOTION_COMMAND out at the command rate.
// Without a fresh pose it may steer with (pilot.hpp) it says nothing, so the motor bridge lets the
// robot stop, and after a second of that its SERVICE_STATUS is WARN with the reason.
#pragma once

#include <cstdint>
#include <optional>

#include <fieldline/motion_command_t.hpp>
#include <fieldline/robot_state_t.hpp>
#include <fieldline/world_state_t.hpp>

#include "common/bus/node.hpp"
#include "services/pilot/pilot.hpp"

namespace fieldline::pilot {

enum class SteerBy { kTruth, kState };

struct PilotNodeOptions {
  // kTruth: SIM_WORLD on `sim_bus`; kState: ROBOT_STATE on the primary bus.
  SteerBy steer = SteerBy::kTruth;
  bus::BusId sim_bus = bus::kPrimaryBus;
  // Commands per second.
  double rate = 50.0;
  // How long each command stays valid (its deadline) [s].
  double command_lifetime = 0.1;
};

// What the pilot reads and writes: steering by `steer` when it drives a scenario, nothing at
// all when it holds still (fieldline-pilot --print-io).
bus::ProcessIo pilotIo(std::optional<SteerBy> driving);

class PilotNode {
 public:
  // Subscribes the pose source and sets the command timer on `node`, whose robot id is the
  // robot steered. Throws std::invalid_argument for a rate or lifetime that is not positive.
  PilotNode(bus::Node& node, Pilot pilot, PilotNodeOptions options);

  std::int64_t commandsSent() const { return commands_sent_; }

 private:
  void onWorld(const world_state_t& w);
  void onState(const robot_state_t& s);
  void sendCommand();

  bus::Node& node_;
  Pilot pilot_;
  PilotNodeOptions options_;
  motion_command_t command_{};
  std::int64_t waiting_ = 0;
  // Since when (node clock) it has sent nothing; -1 while driving.
  Utime holding_since_ = -1;
  static constexpr Utime kHoldWarnAfterUs = kMicrosPerSecond;
  std::int64_t commands_sent_ = 0;
};

// A pilot without a scenario: it holds still by sending nothing (the motor bridge stops the
// robot when commands expire, and a behaviour module or joystick on the bus may drive it). Logs
// it once and reports the metric `holding` = 1 in SERVICE_STATUS, so the status table says so.
void holdStill(bus::Node& node);

}  // namespace fieldline::pilot
