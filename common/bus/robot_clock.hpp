// The clock every process of a robot stamps with. In the simulated team the launcher gives each
// robot's processes its clock error (offset, drift and the time the drift counts from) in the
// FIELDLINE_CLOCK_* variables (common/time/offset_clock.hpp), so six robots disagree about the
// time as six machines do; without them the clock is the system clock.
//
//   const RobotClock clock = bus::robotClockFromEnvironment();
//   bus::Node node({...}, clock);
#pragma once

#include "common/time/offset_clock.hpp"

namespace fieldline::bus {

// The robot's clock error from the environment (zero when none is set); a malformed value is a
// config::Error naming the variable. Logs the error when there is one.
ClockError robotClockErrorFromEnvironment();

inline RobotClock robotClockFromEnvironment() {
  return RobotClock(robotClockErrorFromEnvironment());
}

}  // namespace fieldline::bus
