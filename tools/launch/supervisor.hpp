// Process supervision without any UI: starts every instance in its own process group, collects
// its output line by line, restarts it after a crash with exponential backoff, and stops them
// all (SIGTERM, then SIGKILL after a grace period), reaping every child. Children get
// PR_SET_PDEATHSIG so they die with the launcher even when it is killed with SIGKILL; the
// supervisor makes its process a child subreaper so orphaned grandchildren are reaped too.
//
//   Supervisor sup(plan.instances, {.backoff = {}, .stop_grace_s = 3}, onLine, onEvent);
//   sup.startAll();
//   while (!sup.finished()) {
//     sup.poll(50);
//     if (stop_wanted && !sup.stopping()) sup.requestStop();
//   }
#pragma once

#include <chrono>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <sys/types.h>

#include "tools/launch/backoff.hpp"
#include "tools/launch/plan.hpp"

namespace fieldline::launch {

using SteadyClock = std::chrono::steady_clock;

inline double secondsBetween(SteadyClock::time_point from, SteadyClock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

enum class ProcessState {
  // The executable is not built: never started.
  kMissing,
  kRunning,
  // Ended; restarts when its backoff delay is over.
  kWaiting,
  // Ended on its own with success and its policy does not restart it.
  kExited,
  // Ended on its own with a failure and its policy does not restart it.
  kFailed,
  // Ended because the supervisor stopped it.
  kStopped,
};

std::string toString(ProcessState state);

// How a process ended.
struct ExitStatus {
  bool signaled = false;
  // Exit code, or the signal number when signaled.
  int value = 0;

  bool success() const { return !signaled && value == 0; }
  // "exit code 3", "killed by SIGSEGV".
  std::string describe() const;
};

// Decodes a waitpid() status.
ExitStatus exitStatusFromWait(int wait_status);

// Whether a process that ended with `status` is started again under `policy`.
bool shouldRestart(RestartPolicy policy, const ExitStatus& status);

struct ProcessRecord {
  LaunchInstance instance;
  ProcessState state = ProcessState::kMissing;
  // Process id (also its process group id) while running; -1 otherwise.
  pid_t pid = -1;
  // How many times it was started again after ending.
  int restarts = 0;
  std::optional<ExitStatus> last_exit;
  // What the supervisor last saw go wrong ("killed by SIGKILL after 3.2 s"); empty if nothing.
  std::string last_error;
  SteadyClock::time_point started{};
  SteadyClock::time_point restart_at{};
  RestartBackoff backoff;
  // When it ended within the crash-loop window (not counting stops by the supervisor).
  std::deque<SteadyClock::time_point> recent_ends;
  // It ended crash_loop.restarts times within crash_loop.window_s and is not restarted again.
  bool crash_loop = false;
  // Stopped by restartRobot: started again as soon as it ended, not counted as a crash; killed
  // (SIGKILL) when it has not ended by restart_kill_at (the stop grace period).
  bool restart_now = false;
  SteadyClock::time_point restart_kill_at{};
  // Read end of the pipe carrying the process's stdout and stderr; -1 when closed.
  int output_fd = -1;
  // Output received after the last newline.
  std::string partial_line;
};

struct SupervisorOptions {
  BackoffParams backoff;
  // Time between SIGTERM and SIGKILL when stopping, s.
  double stop_grace_s = 3.0;
  // When a process counts as crash-looping (then: kFailed, not restarted).
  CrashLoopParams crash_loop;
};

class Supervisor {
 public:
  // One complete line of a process's output, without its newline.
  using LineHandler = std::function<void(const ProcessRecord&, std::string_view line)>;
  // A message of the supervisor itself: started, ended, restarting, stopping.
  using EventHandler = std::function<void(const std::string&)>;

  Supervisor(std::vector<LaunchInstance> instances, SupervisorOptions options, LineHandler on_line,
             EventHandler on_event);
  // Kills (SIGKILL) and reaps whatever is still running.
  ~Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Starts every instance whose executable exists.
  void startAll();
  // Waits up to `timeout_ms` for output, handles ended processes, restarts those whose delay is
  // over and, when stopping, sends SIGKILL to what outlived the grace period.
  void poll(int timeout_ms);
  // Sends SIGTERM to every running process group and cancels pending restarts.
  void requestStop();
  // Sends SIGKILL to every running process group now (a second Ctrl-C).
  void killAll();
  // Every process of robot `robot` gets `env` on top of its environment and is restarted: SIGTERM
  // to its group, started again as soon as it ended (a process waiting for its restart takes the
  // new environment then; one that ended for good keeps it for nothing). Returns how many were
  // running. A clock step: the robot's processes on a new FIELDLINE_CLOCK_OFFSET_US.
  int restartRobot(int robot, const std::map<std::string, std::string>& env);

  bool stopping() const { return stopping_; }
  // Nothing is running and nothing will be restarted.
  bool finished() const;
  // Some process ended on its own with a failure and was not restarted, or crash-looped; stays
  // true after a stop.
  bool anyFailed() const;
  int runningCount() const;
  const std::vector<ProcessRecord>& processes() const { return records_; }

 private:
  void start(ProcessRecord& record);
  // Reads one buffer of output, or everything up to EOF or EAGAIN when `drain`.
  void readOutput(ProcessRecord& record, bool drain);
  void flushPartial(ProcessRecord& record);
  void closeOutput(ProcessRecord& record);
  void reapChildren();
  void onEnded(ProcessRecord& record, const ExitStatus& status);
  ProcessRecord* findByPid(pid_t pid);

  std::vector<ProcessRecord> records_;
  SupervisorOptions options_;
  LineHandler on_line_;
  EventHandler on_event_;
  bool stopping_ = false;
  bool killed_ = false;
  SteadyClock::time_point kill_deadline_{};
  std::vector<char> read_buffer_;
};

}  // namespace fieldline::launch
