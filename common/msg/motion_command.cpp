#include "common/msg/motion_command.hpp"

namespace fieldline::msg {

using perception::CommandSource;
static_assert(static_cast<int>(CommandSource::kPilot) == motion_command_t::SOURCE_PILOT);
static_assert(static_cast<int>(CommandSource::kBehavior) == motion_command_t::SOURCE_BEHAVIOR);
static_assert(static_cast<int>(CommandSource::kManual) == motion_command_t::SOURCE_MANUAL);

perception::MotionCommand fromMessage(const motion_command_t& m) {
  perception::MotionCommand c;
  c.utime = m.header.utime;
  c.vx = m.vx;
  c.vy = m.vy;
  c.omega = m.omega;
  c.deadline_utime = m.deadline_utime;
  const bool known =
      m.source >= motion_command_t::SOURCE_PILOT && m.source <= motion_command_t::SOURCE_MANUAL;
  c.source = known ? static_cast<CommandSource>(m.source) : CommandSource::kUnknown;
  return c;
}

void toMessage(const perception::MotionCommand& c, motion_command_t& m) {
  m.header.utime = c.utime;
  m.vx = c.vx;
  m.vy = c.vy;
  m.omega = c.omega;
  m.deadline_utime = c.deadline_utime;
  m.source = static_cast<std::int8_t>(c.source);
}

}  // namespace fieldline::msg
