// The logs a replay reads and writes besides the recording itself (replay_run.hpp): the robot
// id and first time of a log, the oracle-contact and stalled inputs written to scratch files.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/time/clock.hpp"
#include "tools/replay/replay_run.hpp"

namespace fieldline::replay {

// The robot whose log it is: the recording's RECORDING_INFO, else the first ODOMETRY,
// VISION_LINES or CAMERA_IMAGE; throws ReplayArgumentError when none says.
int detectRobotId(const std::string& path);

// The log time of the log's first event (0 for an empty log).
Utime firstLogTime(const std::string& path);

bool contains(const std::vector<std::string>& list, const std::string& item);

// oracle_contact: writes `scratch` with the fed channels of `options.log_path` except
// VISION_OBSTACLES, and in their place one VISION_OBSTACLES frame (an obstacle at the body) at
// every SIM_WORLD sample of the truth log in which the robot touches another robot. Returns the
// number of such samples.
std::int64_t writeOracleContactLog(const ReplayRunOptions& options, int robot_id,
                                   const ClockError& clock, const std::vector<std::string>& fed,
                                   const std::string& scratch);

// stall_s: writes `scratch` with the fed channels of `input` as a starved process receives them
// (ReplayRunOptions::stall_hold, stall_drop), in log-time order.
void writeStalledLog(const ReplayRunOptions& options, const std::string& input,
                     const std::vector<std::string>& fed, const std::string& scratch,
                     ReplayRunResult& result);

}  // namespace fieldline::replay
