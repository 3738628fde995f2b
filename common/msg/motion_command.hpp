// motion_command_t (MOTION_COMMAND) <-> perception::MotionCommand. header.utime <-> utime.
#pragma once

#include <fieldline/motion_command_t.hpp>

#include "common/perception/body.hpp"

namespace fieldline::msg {

perception::MotionCommand fromMessage(const motion_command_t& m);
void toMessage(const perception::MotionCommand& c, motion_command_t& m);

}  // namespace fieldline::msg
