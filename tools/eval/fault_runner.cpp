#include "tools/eval/fault_runner.hpp"

#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

namespace fieldline::eval {
namespace {

// The launch file's process name as its executable is called (fusion -> fieldline-fusion).
std::string executableOf(const std::string& process) {
  std::string name = "fieldline-" + process;
  std::replace(name.begin(), name.end(), '_', '-');
  return name;
}

int robotArgument(const std::vector<std::string>& argv) {
  for (std::size_t i = 0; i + 1 < argv.size(); ++i)
    if (argv[i] == "--robot") return std::atoi(argv[i + 1].c_str());
  return -1;
}

}  // namespace

std::vector<std::pair<pid_t, std::vector<std::string>>> launcherChildren(pid_t launcher) {
  std::vector<std::pair<pid_t, std::vector<std::string>>> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || !std::all_of(name.begin(), name.end(), ::isdigit)) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const auto close = text.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream fields(text.substr(close + 1));
    std::string state;
    pid_t parent = 0;
    fields >> state >> parent;
    if (parent != launcher || state == "Z") continue;
    std::ifstream cmdline(entry.path() / "cmdline");
    std::vector<std::string> argv;
    std::string arg;
    while (std::getline(cmdline, arg, '\0'))
      argv.push_back(arg);
    if (argv.empty()) continue;
    out.emplace_back(static_cast<pid_t>(std::stol(name)), std::move(argv));
  }
  return out;
}

FaultRunner::FaultRunner(pid_t launcher, std::vector<FaultSpec> specs, const Clock& clock,
                         std::chrono::steady_clock::time_point launched, ClockControl clock_control)
    : launcher_(launcher),
      clock_(clock),
      launched_(launched),
      clock_control_(std::move(clock_control)) {
  for (FaultSpec& s : specs)
    pending_.push_back({std::move(s)});
}

FaultRunner::~FaultRunner() {
  finish();
}

void FaultRunner::poll() {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - launched_).count();
  for (Pending& p : pending_) {
    if (!p.started && elapsed >= p.spec.at_s) {
      p.started = true;
      FaultRecord rec;
      rec.spec = p.spec;
      rec.start_utime = clock_.now();
      const bool stall = p.spec.kind == FaultSpec::Kind::kStall;
      rec.processes =
          p.spec.kind == FaultSpec::Kind::kClockStep ? stepClock(p.spec, rec) : signalProcesses(p);
      std::fprintf(stderr, "fault %s: %s %d process(es) at %.1f s\n", p.spec.text.c_str(),
                   stall                                        ? "stopped"
                   : p.spec.kind == FaultSpec::Kind::kClockStep ? "the launcher restarts"
                                                                : "signalled",
                   rec.processes, elapsed);
      if (!stall) {
        rec.end_utime = rec.start_utime;
        p.ended = true;
      }
      p.record = records_.size();
      records_.push_back(rec);
    }
    if (p.started && !p.ended && elapsed >= p.spec.at_s + p.spec.duration_s) {
      for (const pid_t pid : p.stopped)
        ::kill(pid, SIGCONT);
      p.stopped.clear();
      p.ended = true;
      records_[p.record].end_utime = clock_.now();
      std::fprintf(stderr, "fault %s: continued at %.1f s\n", p.spec.text.c_str(), elapsed);
    }
  }
}

int FaultRunner::signalProcesses(Pending& p) {
  const bool stall = p.spec.kind == FaultSpec::Kind::kStall;
  const int signal = stall ? SIGSTOP : p.spec.kind == FaultSpec::Kind::kRestart ? SIGTERM : SIGKILL;
  int reached = 0;
  for (const auto& [pid, argv] : launcherChildren(launcher_)) {
    const std::string exe = std::filesystem::path(argv[0]).filename().string();
    const int robot = robotArgument(argv);
    const bool match =
        stall ? (p.spec.robot == 0 || robot == p.spec.robot)
              : exe == executableOf(p.spec.process) && (p.spec.robot == 0 || robot == p.spec.robot);
    if (!match || ::kill(pid, signal) != 0) continue;
    ++reached;
    if (stall) p.stopped.push_back(pid);
  }
  return reached;
}

int FaultRunner::stepClock(const FaultSpec& spec, FaultRecord& record) {
  if (clock_control_.path.empty()) {
    std::fprintf(stderr, "fault %s: no clock control file (the launcher was not given one)\n",
                 spec.text.c_str());
    return 0;
  }
  ClockError& clock = clock_control_.clocks[spec.robot];
  const ClockError before = clock;
  clock.offset_us += static_cast<Utime>(std::llround(spec.step_s * 1e6));
  // Every stepped robot's offset; written whole and renamed, so the launcher never reads half.
  const std::string temporary = clock_control_.path + ".new";
  bool written = false;
  {
    std::ofstream out(temporary);
    out << "# fieldline-eval's clock steps: ROBOT OFFSET_US\n";
    for (const auto& [robot, error] : clock_control_.clocks)
      out << robot << " " << error.offset_us << "\n";
    out.flush();
    written = static_cast<bool>(out);
  }
  std::error_code ec;
  if (written) std::filesystem::rename(temporary, clock_control_.path, ec);
  int processes = 0;
  for (const auto& [pid, argv] : launcherChildren(launcher_))
    processes += robotArgument(argv) == spec.robot ? 1 : 0;
  if (!written || ec || ::kill(launcher_, SIGUSR1) != 0) {
    // Not stepped: later steps build on the clock the robot still has.
    clock = before;
    std::fprintf(stderr, "fault %s: the launcher was not told (%s)\n", spec.text.c_str(),
                 !written ? ("cannot write " + temporary).c_str()
                 : ec     ? ec.message().c_str()
                          : "SIGUSR1 failed");
    return 0;
  }
  record.clock_after = clock;
  return processes;
}

void FaultRunner::finish() {
  for (Pending& p : pending_) {
    if (!p.started || p.ended) continue;
    for (const pid_t pid : p.stopped)
      ::kill(pid, SIGCONT);
    p.stopped.clear();
    p.ended = true;
    records_[p.record].end_utime = clock_.now();
  }
}

ClockStepWiring clockStepWiring(const std::vector<FaultSpec>& faults, const std::string& out_dir,
                                const launch::RobotClocks& clocks) {
  ClockStepWiring w;
  std::map<int, double> offset_s;
  for (const FaultSpec& f : faults) {
    if (f.kind != FaultSpec::Kind::kClockStep) continue;
    const auto [it, first] = offset_s.try_emplace(f.robot, 0.0);
    if (first) it->second = static_cast<double>(clocks.of(f.robot).offset_us) * 1e-6;
    double& o = it->second;
    o += f.step_s;
    if (std::fabs(o) > launch::kMaxControlledOffsetS)
      throw std::invalid_argument(fmt::format(
          "fault '{}': robot {}'s clock would be {:+.3f} s off the true time (its launch file "
          "offset and the steps before); the launcher takes at most {} s either way",
          f.text, f.robot, o, launch::kMaxControlledOffsetS));
    w.ahead_us = std::max(w.ahead_us, static_cast<Utime>(std::llround(o * 1e6)));
  }
  if (offset_s.empty()) return w;
  w.control.path = out_dir + "/clock_control";
  std::filesystem::remove(w.control.path);
  w.control.clocks = clocks.by_robot;
  for (const auto& [robot, o] : offset_s)
    w.control.clocks.try_emplace(robot);
  return w;
}

pid_t startCpuHog(double seconds) {
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != parent) ::_exit(0);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  volatile unsigned long spin = 0;
  while (std::chrono::steady_clock::now() < end) {
    for (int i = 0; i < 100000; ++i)
      spin = spin + 1;
  }
  ::_exit(0);
}

}  // namespace fieldline::eval
