// Launch parity: a real robot runs every per-robot process the simulated team runs (issue 29).
// Both launch files include config/launch/robot_processes.yaml, so they share one description;
// this check catches what an include cannot: a per-robot process added to the team's file
// alone, one the robot's file leaves out (`enabled: false`), or another executable under the
// same name. Plain function: launch files in, problems out (ctest -R launch_parity).
#pragma once

#include <string>
#include <vector>

#include "tools/launch/launch_file.hpp"

namespace fieldline::launch {

// Names of the processes `file` runs for robots (not only for `sim`), in file order.
std::vector<std::string> perRobotProcesses(const LaunchFile& file);

// One problem per per-robot process of `team` that `robot` does not run for its robot (its
// defaults.robot, else robot 1), or runs with another executable: "fusion (sim_team.yaml:61):
// missing from real_robot.yaml". Empty when the robot runs them all.
std::vector<std::string> parityProblems(const LaunchFile& team, const LaunchFile& robot);

}  // namespace fieldline::launch
