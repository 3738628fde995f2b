// Carries out fieldline-eval's faults (faults.hpp) on the team a fieldline-launch runs: signals to
// the launcher's own children, found in /proc by their executable and `--robot N` argument (only
// this launcher's children: other runs on the machine are never touched), and a CPU hog. A clock
// step is the launcher's to do (it restarts the robot's processes with their new clock): the
// runner writes the robots' new offsets into the launcher's --clock-control file and sends it
// SIGUSR1 (tools/launch/robot_clocks.hpp).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <map>
#include <string>
#include <vector>

#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"
#include "tools/eval/faults.hpp"
#include "tools/launch/robot_clocks.hpp"

namespace fieldline::eval {

// A fault as it happened, on the true (system) clock.
struct FaultRecord {
  FaultSpec spec;
  Utime start_utime = 0;
  Utime end_utime = 0;
  int processes = 0;
  // Clock steps: the robot's clock from the step on.
  ClockError clock_after;
};

// Where clock steps go: the launcher's --clock-control file, and the robots' clocks before any
// step (the launch file's).
struct ClockControl {
  std::string path;
  std::map<int, ClockError> clocks;
};

class FaultRunner {
 public:
  // `specs`' times count from `launched` (the launcher's start).
  FaultRunner(pid_t launcher, std::vector<FaultSpec> specs, const Clock& clock,
              std::chrono::steady_clock::time_point launched, ClockControl clock_control = {});
  FaultRunner(const FaultRunner&) = delete;
  FaultRunner& operator=(const FaultRunner&) = delete;
  // Continues whatever is still stopped.
  ~FaultRunner();
  // Acts on every fault that is due; call often (every few tens of ms).
  void poll();
  // Continues every stalled process now (the run is ending).
  void finish();
  const std::vector<FaultRecord>& records() const { return records_; }

 private:
  struct Pending {
    FaultSpec spec;
    bool started = false;
    bool ended = false;
    std::vector<pid_t> stopped;
    std::size_t record = 0;
  };
  // Signals the processes a restart, kill or stall is for; returns how many it reached.
  int signalProcesses(Pending& p);
  // Steps the robot's clock: the control file rewritten, the launcher told; the robot's
  // processes it found (the launcher restarts them).
  int stepClock(const FaultSpec& spec, FaultRecord& record);
  pid_t launcher_;
  const Clock& clock_;
  std::chrono::steady_clock::time_point launched_;
  std::vector<Pending> pending_;
  std::vector<FaultRecord> records_;
  ClockControl clock_control_;
};

// The clock steps of a run (--fault clockstep): the launcher's control file (out_dir/clock_control;
// none without a clock step), and how far ahead of the true time a robot's clock may get.
struct ClockStepWiring {
  ClockControl control;
  Utime ahead_us = 0;
};

// Throws std::invalid_argument when a robot's clock would get further off than the launcher takes.
ClockStepWiring clockStepWiring(const std::vector<FaultSpec>& faults, const std::string& out_dir,
                                const launch::RobotClocks& clocks);

// The launcher's live children as (pid, argv).
std::vector<std::pair<pid_t, std::vector<std::string>>> launcherChildren(pid_t launcher);

// A bounded busy loop on one core: a child process that spins until `seconds` have passed or
// its parent dies, whichever is first. Returns its pid (-1: fork failed).
pid_t startCpuHog(double seconds);

}  // namespace fieldline::eval
