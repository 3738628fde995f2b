// Who may drive this robot. MOTION_COMMAND's header names the robot a command is for
// (header.robot_id) and the process that sent it (header.publisher_id, drawn at random by every
// process at start). The bridge obeys commands for its own robot from one publisher at a time:
// - a command claiming another robot (or 0, a tool's id) is refused and counted: nothing on this
//   robot's bus may drive it in another robot's name (the red team drove robot 1 at 2.1 m/s as
//   "robot 2" while the bridge said ok);
// - the first publisher heard is the driver; a command from another publisher, whatever robot it
//   claims, is refused while the driver was heard within kDriverSilenceUs, so a second driver
//   never mixes its commands with the first one's. A driver silent that long (a restarted pilot
//   draws a new id) hands over to the next publisher.
// Both keep the bridge's status at WARN, with who and how often, for kWarnHoldUs after the last
// refusal. Plain logic on the header's fields and the time the caller passes in.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "common/time/clock.hpp"

namespace fieldline::motor_bridge {

class CommandSource {
 public:
  // The driver's commands come at 30-50 Hz; a gap this long is a driver that stopped.
  static constexpr Utime kDriverSilenceUs = 500'000;
  static constexpr Utime kWarnHoldUs = 10 * kMicrosPerSecond;

  enum class Verdict : std::int8_t { kAccept, kOtherRobot, kSecondPublisher };
  struct Result {
    Verdict verdict = Verdict::kAccept;
    // Why it was refused, for the error log; empty when accepted.
    std::string reason;
  };

  explicit CommandSource(int robot_id) : robot_id_(robot_id) {}

  // A MOTION_COMMAND from (robot_id, publisher_id) received at `now`.
  Result onCommand(int robot_id, std::int64_t publisher_id, Utime now);
  // The warning for SERVICE_STATUS at `now`: empty when nothing was refused for kWarnHoldUs.
  std::string warning(Utime now) const;

  std::int64_t refusedOtherRobot() const { return refused_other_robot_; }
  std::int64_t refusedSecondPublisher() const { return refused_second_publisher_; }
  // The publisher whose commands are obeyed, if any.
  std::optional<std::int64_t> driver() const { return driver_; }

 private:
  int robot_id_;
  std::optional<std::int64_t> driver_;
  Utime driver_seen_ = 0;
  std::int64_t refused_other_robot_ = 0;
  std::int64_t refused_second_publisher_ = 0;
  Utime last_refused_ = -1;
  std::string last_reason_;
};

}  // namespace fieldline::motor_bridge
