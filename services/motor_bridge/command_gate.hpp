// Which motion command a motor controller should be sent now, whatever protocol it speaks: a
// command with a NaN is refused, values are clamped to [-1, 1], an expired one is ignored, no
// command lives longer than kMaxCommandLifetimeUs after it arrived, and once the current one's
// deadline passes the controller is sent zero. Plain logic on times the caller passes in; counts
// what it refuses by kind ("command_nan", "command_expired", ...) into the caller's counters.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "common/time/clock.hpp"

namespace fieldline::motor_bridge {

struct CommandInput {
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;
  Utime deadline = 0;
};

class CommandGate {
 public:
  // No command drives the robot longer than this after it arrived, whatever its deadline says.
  static constexpr Utime kMaxCommandLifetimeUs = 500'000;

  explicit CommandGate(std::map<std::string, std::uint64_t>& counters) : counters_(counters) {}

  // A motion command received at `now`. Returns false (and counts why) when it is not used.
  bool onCommand(const CommandInput& command, Utime now);
  // The command to send at `now`: the current one, or zero once its deadline passed (counted
  // "command_timeout" once) or when there is none.
  const CommandInput& due(Utime now);
  // Forgets the current command (a stop).
  void clear();
  bool active(Utime now) const { return have_command_ && now <= current_.deadline; }
  bool hasCommand() const { return have_command_; }
  // The command being sent, after clamping (zero if none).
  const CommandInput& current() const { return current_; }

 private:
  std::map<std::string, std::uint64_t>& counters_;
  CommandInput current_;
  bool have_command_ = false;
};

}  // namespace fieldline::motor_bridge
