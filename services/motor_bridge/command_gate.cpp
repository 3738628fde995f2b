#include "services/motor_bridge/command_gate.hpp"

#include <algorithm>
#include <cmath>

namespace fieldline::motor_bridge {

bool CommandGate::onCommand(const CommandInput& command, Utime now) {
  if (!std::isfinite(command.vx) || !std::isfinite(command.vy) || !std::isfinite(command.omega)) {
    ++counters_["command_nan"];
    return false;
  }
  if (command.deadline < now) {
    ++counters_["command_expired"];
    return false;
  }
  CommandInput accepted = command;
  if (accepted.deadline > now + kMaxCommandLifetimeUs) {
    // A far deadline would keep the robot driving (and the controller's watchdog fed) long after
    // its source died: no command lives longer than this here.
    ++counters_["command_deadline_clamped"];
    accepted.deadline = now + kMaxCommandLifetimeUs;
  }
  const bool out_of_range =
      std::abs(command.vx) > 1.0 || std::abs(command.vy) > 1.0 || std::abs(command.omega) > 1.0;
  if (out_of_range) ++counters_["command_clamped"];
  current_ = {std::clamp(command.vx, -1.0, 1.0), std::clamp(command.vy, -1.0, 1.0),
              std::clamp(command.omega, -1.0, 1.0), accepted.deadline};
  have_command_ = true;
  return true;
}

const CommandInput& CommandGate::due(Utime now) {
  if (have_command_ && now > current_.deadline) {
    // The source went quiet: stop the robot rather than keep its last wish.
    have_command_ = false;
    current_ = {};
    ++counters_["command_timeout"];
  }
  return current_;
}

void CommandGate::clear() {
  have_command_ = false;
  current_ = {};
}

}  // namespace fieldline::motor_bridge
