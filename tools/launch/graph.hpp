// The data flow of a launch file (fieldline-launch --graph): every instance is asked what it
// reads and writes with its own command line (`--print-io`, common/bus/io.hpp), and the answers
// are joined per bus: the simulator's bus, each robot's bus, and what travels outside LCM (serial
// lines, cameras, the team network). A required input that no process of the launch writes is a
// problem: the launch cannot work.
#pragma once

#include <string>
#include <vector>

#include "common/bus/io.hpp"
#include "tools/launch/plan.hpp"
#include "tools/launch/preflight.hpp"

namespace fieldline::launch {

// The option every fieldline process answers with its declaration.
inline constexpr const char* kPrintIoOption = "--print-io";

struct InstanceIo {
  LaunchInstance instance;
  bus::ProcessIo io;
};

struct LaunchGraph {
  std::vector<InstanceIo> nodes;
  // Instances that did not answer --print-io (refused, not a fieldline process).
  std::vector<std::string> problems;
  // Instances not built ("sim viewer"): left out (checkExecutables says whether that is an error).
  std::vector<std::string> skipped;
};

// Asks every instance of `plan` for its declaration.
LaunchGraph queryGraph(const LaunchPlan& plan, const PreflightOptions& options = {});

// One line per required input without a writer on its bus:
// "r1 fusion reads ODOMETRY on robot 1's bus: no process of the launch writes it".
std::vector<std::string> missingWriters(const std::vector<InstanceIo>& nodes);

// The graph as text: per bus, every process with what it reads (and from whom) and writes (and
// to whom), then its links outside LCM, and at the end the inputs without a writer.
std::string formatGraph(const std::vector<InstanceIo>& nodes);

}  // namespace fieldline::launch
