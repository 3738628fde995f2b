// The simulated team's robot clocks: the launch file's optional `robots:` section gives robot N a
// clock error, and every process the launcher starts for robot N gets it in the FIELDLINE_CLOCK_*
// variables (common/time/offset_clock.hpp), so all of robot N's processes share one clock and
// disagree with the other robots as six machines would.
//
//   robots:
//     - {id: 1, clock: {offset_s: 0.31, drift_ppm: -22}}
//     - {id: 2, clock: {offset_s: -0.45, drift_ppm: 41}}
//
// The drift counts from one reference time, the same for every process of the team: the
// FIELDLINE_CLOCK_REFERENCE_US of the launcher's own environment when set (so fieldline-eval,
// which starts the launcher, knows it), else the time the launch file was read.
#pragma once

#include <map>
#include <string>

#include "common/config/config.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline::launch {

// Largest clock offset a launch file may give, s: a robot's messages reach the team's tools
// (launcher, viewer, evaluation) only within their stamp windows (bus::NodeOptions).
inline constexpr double kMaxClockOffsetS = 1.0;
// Largest drift, ppm.
inline constexpr double kMaxClockDriftPpm = 200.0;

struct RobotClocks {
  // Clock error per robot number; robots not listed keep the true clock.
  std::map<int, ClockError> by_robot;

  // The error of robot `robot` (zero when it has none).
  ClockError of(int robot) const;
};

// Reads the optional `robots:` list of the launch file's root (each entry {id: 1..99, clock:
// {offset_s, drift_ppm}}, ids unique); `reference_us` becomes every robot's reference time.
// Throws config::Error naming file:line and key.
RobotClocks parseRobotClocks(const config::Node& root, Utime reference_us);

// The reference time for a launch now: FIELDLINE_CLOCK_REFERENCE_US if set (must be a number),
// else the system clock.
Utime clockReferenceNow();

// fieldline-launch --clock-control FILE: on SIGUSR1 the launcher reads FILE and restarts every
// process of each robot listed whose clock offset it changes, with FIELDLINE_CLOCK_OFFSET_US set
// to the new one (a clock step: an NTP step, a reboot with a wrong clock; fieldline-eval's
// clockstep fault). One robot a line, `ROBOT OFFSET_US`; `#` starts a comment.
//   1 2000000      # robot 1's clock 2 s ahead of the true time
// Largest offset, s: the launcher's status feed takes stamps this far ahead.
inline constexpr double kMaxControlledOffsetS = 10.0;
// Robot -> offset, µs. Throws config::Error naming `origin`:line for a malformed line, a robot
// outside 1..99, one listed twice, or an offset beyond kMaxControlledOffsetS.
std::map<int, Utime> parseClockControl(const std::string& text, const std::string& origin);

// The environment that gives a process the clock `error` (empty for a true clock).
std::map<std::string, std::string> clockEnvironment(const ClockError& error);

}  // namespace fieldline::launch
