// Supervision with real child processes (/bin/sh): output lines, restarts, stop and kill.
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <functional>
#include <string>
#include <vector>

#include "tools/launch/supervisor.hpp"

namespace fieldline::launch {
namespace supervisor_test {

LaunchInstance shell(const std::string& name, const std::string& script,
                     RestartPolicy restart = RestartPolicy::kNever) {
  LaunchInstance i;
  i.name = name;
  i.robot = 1;
  i.executable = "sh";
  i.path = "/bin/sh";
  i.argv = {"/bin/sh", "-c", script};
  i.restart = restart;
  return i;
}

class SupervisorTest : public ::testing::Test {
 protected:
  std::unique_ptr<Supervisor> make(std::vector<LaunchInstance> instances,
                                   SupervisorOptions options = fastOptions()) {
    return std::make_unique<Supervisor>(
        std::move(instances), options,
        [this](const ProcessRecord& r, std::string_view line) {
          lines.push_back(r.instance.label() + ": " + std::string(line));
        },
        [this](const std::string& e) { events.push_back(e); });
  }
  static SupervisorOptions fastOptions() {
    return SupervisorOptions{.backoff = {.initial_s = 0.01, .max_s = 0.02, .stable_s = 60},
                             .stop_grace_s = 0.3};
  }
  // Polls until `done` holds; false if it never did within many polls (a hang, not a timing
  // assertion).
  static bool pollUntil(Supervisor& s, const std::function<bool()>& done) {
    for (int i = 0; i < 3000; ++i) {
      if (done()) return true;
      s.poll(10);
    }
    return done();
  }
  bool hasLine(const std::string& line) const {
    return std::find(lines.begin(), lines.end(), line) != lines.end();
  }

  std::vector<std::string> lines;
  std::vector<std::string> events;
};

TEST_F(SupervisorTest, RestartRobotRestartsItsProcessesAtOnceOnTheNewEnvironment) {
  // Two processes of robot 1 and one of robot 2, each printing its clock and waiting; the
  // restart policy says never, and the restart is not a crash.
  const std::string script = "echo offset=${FIELDLINE_CLOCK_OFFSET_US:-0}; exec sleep 30";
  LaunchInstance other = shell("b", script);
  other.robot = 2;
  auto s = make({shell("a", script), shell("c", script), other});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return lines.size() == 3; }));
  EXPECT_EQ(s->restartRobot(1, {{"FIELDLINE_CLOCK_OFFSET_US", "2000000"}}), 2);
  ASSERT_TRUE(pollUntil(*s, [&] { return lines.size() == 5; }));
  EXPECT_EQ(std::count(lines.begin(), lines.end(), "r1 a: offset=2000000"), 1);
  EXPECT_EQ(std::count(lines.begin(), lines.end(), "r1 c: offset=2000000"), 1);
  EXPECT_EQ(std::count(lines.begin(), lines.end(), "r2 b: offset=0"), 1);
  for (const ProcessRecord& r : s->processes()) {
    EXPECT_EQ(r.state, ProcessState::kRunning) << r.instance.label();
    EXPECT_EQ(r.restarts, r.instance.robot == 1 ? 1 : 0) << r.instance.label();
    EXPECT_EQ(r.backoff.consecutiveFailures(), 0) << r.instance.label();
  }
  s->requestStop();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
}

// A process that ignores SIGTERM is killed after the stop grace period and still restarted on
// the new environment (a clock step must not leave a robot half on its old clock).
TEST_F(SupervisorTest, RestartRobotKillsAProcessThatIgnoresTheStop) {
  auto s = make({shell("stubborn",
                       "trap '' TERM; echo offset=${FIELDLINE_CLOCK_OFFSET_US:-0}; "
                       "while :; do sleep 0.05; done")});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return lines.size() == 1; }));
  EXPECT_EQ(s->restartRobot(1, {{"FIELDLINE_CLOCK_OFFSET_US", "-2000000"}}), 1);
  ASSERT_TRUE(pollUntil(*s, [&] { return lines.size() == 2; }));
  EXPECT_EQ(lines.back(), "r1 stubborn: offset=-2000000");
  EXPECT_TRUE(std::any_of(events.begin(), events.end(), [](const std::string& e) {
    return e.find("did not stop within 0.3 s for its restart: SIGKILL") != std::string::npos;
  }));
  s->killAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
}

TEST_F(SupervisorTest, ForwardsOutputLineByLine) {
  auto s = make({shell("talker", "echo one; echo two >&2; printf 'three\\r\\nfour'")});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
  EXPECT_EQ(lines, (std::vector<std::string>{"r1 talker: one", "r1 talker: two", "r1 talker: three",
                                             "r1 talker: four"}));
  const ProcessRecord& r = s->processes()[0];
  EXPECT_EQ(r.state, ProcessState::kExited);
  ASSERT_TRUE(r.last_exit.has_value());
  EXPECT_TRUE(r.last_exit->success());
  EXPECT_EQ(r.pid, -1);
  EXPECT_FALSE(s->anyFailed());
}

TEST_F(SupervisorTest, PassesEnvironmentAndClosesStdin) {
  LaunchInstance i = shell("env", "echo value=$FIELDLINE_LAUNCH_TEST_VAR; cat; echo after-cat");
  i.env["FIELDLINE_LAUNCH_TEST_VAR"] = "42";
  auto s = make({i});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
  EXPECT_TRUE(hasLine("r1 env: value=42"));
  EXPECT_TRUE(hasLine("r1 env: after-cat"));  // stdin is /dev/null: cat ends at once
}

TEST_F(SupervisorTest, RestartsAFailingProcessWithBackoff) {
  auto s = make({shell("crasher", "echo run; exit 3", RestartPolicy::kOnFailure)});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->processes()[0].restarts >= 3; }));
  const ProcessRecord& r = s->processes()[0];
  EXPECT_EQ(r.backoff.consecutiveFailures(), 3);
  EXPECT_EQ(r.last_exit->describe(), "exit code 3");
  EXPECT_EQ(r.last_error.rfind("exit code 3 after ", 0), 0u) << r.last_error;
  EXPECT_GE(std::count(lines.begin(), lines.end(), "r1 crasher: run"), 3);
  s->requestStop();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
  EXPECT_EQ(s->processes()[0].state, ProcessState::kStopped);
}

TEST_F(SupervisorTest, PolicyDecidesAboutRestarts) {
  auto s = make({shell("ok_once", "exit 0", RestartPolicy::kOnFailure),
                 shell("fail_once", "exit 1", RestartPolicy::kNever),
                 shell("always", "exit 0", RestartPolicy::kAlways)});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->processes()[2].restarts >= 2; }));
  ASSERT_TRUE(pollUntil(*s, [&] {
    return s->processes()[0].state == ProcessState::kExited &&
           s->processes()[1].state == ProcessState::kFailed;
  }));
  EXPECT_EQ(s->processes()[0].restarts, 0);
  EXPECT_EQ(s->processes()[1].restarts, 0);
  EXPECT_TRUE(s->anyFailed());
  EXPECT_FALSE(s->finished());  // `always` keeps going
  s->requestStop();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
}

TEST_F(SupervisorTest, ShouldRestartTable) {
  const ExitStatus ok{false, 0}, code{false, 2}, signal{true, SIGSEGV};
  EXPECT_TRUE(shouldRestart(RestartPolicy::kAlways, ok));
  EXPECT_TRUE(shouldRestart(RestartPolicy::kAlways, signal));
  EXPECT_FALSE(shouldRestart(RestartPolicy::kOnFailure, ok));
  EXPECT_TRUE(shouldRestart(RestartPolicy::kOnFailure, code));
  EXPECT_TRUE(shouldRestart(RestartPolicy::kOnFailure, signal));
  EXPECT_FALSE(shouldRestart(RestartPolicy::kNever, signal));
  EXPECT_EQ(signal.describe(), "killed by SIGSEGV");
  EXPECT_EQ(code.describe(), "exit code 2");
}

TEST_F(SupervisorTest, StopSendsSigtermToTheGroup) {
  auto s = make({shell("sleeper", "echo ready; exec sleep 60", RestartPolicy::kAlways)});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return hasLine("r1 sleeper: ready"); }));
  const pid_t pid = s->processes()[0].pid;
  ASSERT_GT(pid, 0);
  EXPECT_EQ(::getpgid(pid), pid);  // its own process group
  s->requestStop();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
  const ProcessRecord& r = s->processes()[0];
  EXPECT_EQ(r.state, ProcessState::kStopped);
  EXPECT_EQ(r.last_exit->describe(), "killed by SIGTERM");
  EXPECT_EQ(r.restarts, 0);
  EXPECT_EQ(::kill(pid, 0), -1);
}

TEST_F(SupervisorTest, KillsWhatIgnoresSigtermAndReapsGrandchildren) {
  // The shell ignores SIGTERM and so does its background child (ignored signals are
  // inherited); both must go with the SIGKILL after the grace period.
  auto s = make({shell("stubborn", "trap '' TERM; sleep 60 & echo child $!; wait")});
  s->startAll();
  std::string child_line;
  ASSERT_TRUE(pollUntil(*s, [&] {
    for (const auto& l : lines) {
      if (l.rfind("r1 stubborn: child ", 0) == 0) child_line = l;
    }
    return !child_line.empty();
  }));
  const pid_t grandchild = std::stoi(child_line.substr(std::string("r1 stubborn: child ").size()));
  s->requestStop();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
  EXPECT_EQ(s->processes()[0].last_exit->describe(), "killed by SIGKILL");
  EXPECT_NE(std::find_if(events.begin(), events.end(),
                         [](const std::string& e) {
                           return e == "r1 stubborn did not stop within 0.3 s: SIGKILL";
                         }),
            events.end());
  // The grandchild was re-parented to us (subreaper) and is reaped by later polls.
  ASSERT_TRUE(pollUntil(*s, [&] { return ::kill(grandchild, 0) == -1 && errno == ESRCH; }));
}

TEST_F(SupervisorTest, ExecFailureIsReportedAndCountsAsFailure) {
  LaunchInstance i = shell("ghost", "");
  i.path = "/nonexistent/fieldline-ghost";
  i.argv = {i.path};
  auto s = make({i});
  s->startAll();
  ASSERT_TRUE(pollUntil(*s, [&] { return s->finished(); }));
  EXPECT_TRUE(
      hasLine("r1 ghost: fieldline-launch: cannot execute /nonexistent/fieldline-ghost: "
              "errno " +
              std::to_string(ENOENT)));
  EXPECT_EQ(s->processes()[0].state, ProcessState::kFailed);
  EXPECT_EQ(s->processes()[0].last_exit->describe(), "exit code 127");
}

TEST_F(SupervisorTest, MissingExecutableIsNeverStarted) {
  LaunchInstance i = shell("camera", "");
  i.path.clear();
  auto s = make({i});
  s->startAll();
  EXPECT_TRUE(s->finished());
  EXPECT_EQ(s->processes()[0].state, ProcessState::kMissing);
  EXPECT_EQ(s->runningCount(), 0);
  EXPECT_TRUE(events.empty());
}

TEST_F(SupervisorTest, DestructorLeavesNothingRunning) {
  pid_t pid = -1;
  {
    auto s = make({shell("sleeper", "echo ready; exec sleep 60")});
    s->startAll();
    ASSERT_TRUE(pollUntil(*s, [&] { return hasLine("r1 sleeper: ready"); }));
    pid = s->processes()[0].pid;
  }
  EXPECT_EQ(::kill(pid, 0), -1);
}

}  // namespace supervisor_test
}  // namespace fieldline::launch
