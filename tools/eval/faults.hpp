// Fault scenarios for the evaluation (issue 34 item 3, issue 32 item 2): what fieldline-eval does
// to the running team (a process restarted or killed, a robot's or the whole machine's processes
// stalled with SIGSTOP/SIGCONT, a robot's processes restarted on a stepped clock, a CPU hog), and
// how the robots came through it: per fault the
// time to recover and the largest error while TRACKING; over the run the figures the issues'
// must-show items name (largest error and p99 while TRACKING, the share of time not TRACKING).
//
// Plain library: parsing and scoring only. The signals are sent by fieldline-eval (fault_runner).
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "tools/eval/evaluation.hpp"

namespace fieldline::eval {

// One fault, as given on the command line:
//   restart:PROCESS[/ROBOT]@T   SIGTERM (a clean stop, as systemctl restart sends): the launcher
//                               restarts it; world_sim and viewer have no robot
//   kill:PROCESS[/ROBOT]@T      SIGKILL, the same otherwise
//   stall:ROBOT@T+D             SIGSTOP every process of robot ROBOT, SIGCONT D s later
//   stall:all@T+D               ... every process of the team, the simulator too (the machine)
//   clockstep:ROBOT@T+S, @T-S   robot ROBOT's processes restarted (by the launcher) on its clock
//                               stepped by +-S s (an NTP step, a reboot with a wrong clock)
// T: seconds after the launcher started. PROCESS: a launch file process name (fusion, camera,
// region_tracking, feature_recognition, motor_bridge, pilot, teamcomm, world_sim, viewer).
// Without /ROBOT a robot's process is restarted on every robot at once.
struct FaultSpec {
  enum class Kind { kRestart, kKill, kStall, kClockStep };
  Kind kind = Kind::kRestart;
  std::string process;  // empty for a stall and a clock step
  int robot = 0;        // 0: every robot (or the simulator's own process)
  double at_s = 0.0;
  double duration_s = 0.0;  // stalls only
  double step_s = 0.0;      // clock steps only: how far the robot's clock jumps (+ ahead)
  std::string text;         // as given
};

// Largest clock step, s: the team's tools (fieldline-eval, the launcher's status table) widen their
// stamp windows by the robots' stepped offsets, up to this.
inline constexpr double kMaxClockStepS = 10.0;
// Smallest clock step, s: fieldline-eval tells a robot's old clock from its new one by which puts
// a message's publish stamp nearer its arrival, which needs the step well above the bus latency.
inline constexpr double kMinClockStepS = 0.05;

// Throws std::invalid_argument naming what is wrong with `text`.
FaultSpec parseFault(const std::string& text);

// What a teammate's TEAM_STATE said of the team, in the evaluation's time (s since the first
// ROBOT_STATE; the teammate's stamp taken out through its clock). Index i is robot i+1.
struct TeamLinkSample {
  int robot = 0;  // the teammate that published it
  double t = 0.0;
  std::array<bool, 6> present{};
  // When the pose it holds of robot i+1 was taken (t - robot_age_us), s.
  std::array<double, 6> pose_t{};
  std::array<int, 6> rejected{};  // packets_rejected
};

// What happened, in the evaluation's time (s since the first ROBOT_STATE, as Matched::t).
struct FaultEvent {
  FaultSpec spec;
  double start_t = 0.0;
  double end_t = 0.0;
  // Processes the signal reached (0: the fault found nothing to act on).
  int processes = 0;
  // Clock steps: the stepped robot's first message on its new clock (its restarted processes),
  // eval time; a teammate has heard it again only from a pose of then or later (before, its old
  // processes still send on the old clock). Unset: end_t; infinity: never published.
  std::optional<double> new_clock_t;
};

struct RobustnessOptions {
  // A robot has recovered when it tracks within this of the truth for hold_s, m and s.
  double recovered_m = 0.2;
  double hold_s = 1.0;
  // Samples further apart than this break a stretch (a process that published nothing), s.
  double max_gap_s = 0.25;
  // TRACKING samples further than this from the truth are counted, m (issues 32 and 34: 0.5 m).
  double limit_m = 0.5;
  // A fault's errors are looked at from its start until this long after its end, s.
  double after_s = 10.0;
  // A teammate hears a stepped robot again when it holds a pose of it this fresh, s.
  double heard_age_s = 0.5;
};

struct FaultResult {
  FaultEvent event;
  // Per affected robot: seconds from the fault's end to the start of its first stretch of
  // hold_s TRACKING within recovered_m (-1: never within the run).
  std::map<int, double> recovery_s;
  double recovery_max_s = 0.0;  // -1 when any robot never recovered
  // Largest position error of a TRACKING sample of an affected robot between the fault's start
  // and after_s past its end, and how many such samples were beyond limit_m.
  double max_tracking_error_m = 0.0;
  int tracking_over_limit = 0;
  // The same without twin-ambiguous samples.
  double certain_max_m = 0.0;
  int certain_over_limit = 0;
  // Clock steps: per teammate, seconds from the step to its first TEAM_STATE with the stepped
  // robot present and holding a pose taken after the step and at most heard_age_s old (-1:
  // never within the run); and how many of the stepped robot's packets the teammates refused
  // (packets_rejected) from the step until they heard it again (or the run's end).
  std::map<int, double> heard_again_s;
  int packets_refused = 0;
};

struct Robustness {
  // Over every matched sample with status TRACKING (start-up included: nothing is excused).
  std::size_t tracking_samples = 0;
  double tracking_max_m = 0.0;
  double tracking_p99_m = 0.0;
  double tracking_mean_m = 0.0;
  int tracking_over_limit = 0;
  // The same over the TRACKING samples that were not twin-ambiguous (ROBOT_STATE's
  // twin_ambiguous: a pose that says it may be its symmetric twin), and how many were.
  double certain_max_m = 0.0;
  int certain_over_limit = 0;
  std::size_t twin_ambiguous_samples = 0;
  // Where the largest error was: robot and t.
  int worst_robot = 0;
  double worst_t = 0.0;
  // Share of time not TRACKING, from each robot's first TRACKING to its last sample, time
  // weighted: a sample holds its status until the next one, for at most max_gap_s (a silence
  // beyond counts as not TRACKING).
  double not_tracking_share = 0.0;
  std::map<int, double> not_tracking_share_by_robot;
  std::vector<FaultResult> faults;
  // VISION_LINES per second per robot over the run (filled by the caller; empty: not known).
  std::map<int, double> vision_lines_hz;
};

// `robots`: the team's robot numbers (who a fault of every robot, or of the simulator, affects).
// `team`: the teammates' TEAM_STATE (for the clock steps' heard_again_s).
Robustness evaluateRobustness(const Summary& summary, const std::vector<FaultEvent>& events,
                              const std::vector<int>& robots, const RobustnessOptions& options = {},
                              const std::vector<TeamLinkSample>& team = {});

// One line: the run's figures; then one line per fault.
std::string robustnessLines(const Robustness& r, const RobustnessOptions& options = {});
std::string robustnessJson(const Robustness& r, const RobustnessOptions& options = {});

}  // namespace fieldline::eval
