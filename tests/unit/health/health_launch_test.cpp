// Issue 13 findings 6 and 7, the launcher's part without a bus: a child that crash-loops is
// failed (not restarted forever) and makes the run a failure; the preflight runs every child
// with --check-args and reports a rejected argument, and an executable name that is not found
// is an error naming the closest built one. The end-to-end runs are health_launch_integration.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "tools/launch/preflight.hpp"
#include "tools/launch/supervisor.hpp"

namespace fieldline::launch {
namespace health_launch_test {

LaunchInstance shell(const std::string& name, const std::string& script,
                     RestartPolicy restart = RestartPolicy::kAlways) {
  LaunchInstance i;
  i.name = name;
  i.robot = 1;
  i.executable = "sh";
  i.path = "/bin/sh";
  // --check-args is appended after the script: it becomes $0, the script ignores it.
  i.argv = {"/bin/sh", "-c", script};
  i.restart = restart;
  return i;
}

bool pollUntil(Supervisor& s, const std::function<bool()>& done) {
  for (int i = 0; i < 3000; ++i) {
    if (done()) return true;
    s.poll(10);
  }
  return done();
}

bool contains(const std::vector<std::string>& texts, const std::string& part) {
  return std::any_of(texts.begin(), texts.end(),
                     [&](const std::string& t) { return t.find(part) != std::string::npos; });
}

TEST(HealthLaunch, ACrashLoopIsFailedAndNotRestartedForever) {
  std::vector<std::string> events;
  Supervisor s(
      {shell("looper", "echo bad argument >&2; exit 2"), shell("steady", "exec sleep 60")},
      SupervisorOptions{.backoff = {.initial_s = 0.01, .max_s = 0.02, .stable_s = 60},
                        .stop_grace_s = 0.3,
                        .crash_loop = {.restarts = 4, .window_s = 30}},
      [](const ProcessRecord&, std::string_view) {},
      [&](const std::string& e) { events.push_back(e); });
  s.startAll();
  // Before: restarted every 0.5..10 s forever, the state `waiting`, the exit code 0.
  ASSERT_TRUE(pollUntil(s, [&] { return s.processes()[0].state == ProcessState::kFailed; }));
  const ProcessRecord& looper = s.processes()[0];
  EXPECT_TRUE(looper.crash_loop);
  EXPECT_EQ(looper.restarts, 3);  // four ends: started, restarted three times, then given up
  EXPECT_NE(looper.last_error.find("crash loop: ended 4 times within 30 s, last: exit code 2"),
            std::string::npos)
      << looper.last_error;
  EXPECT_TRUE(contains(events, "r1 looper FAILED: crash loop"));
  EXPECT_TRUE(s.anyFailed());
  // It stays failed through a stop (--duration or Ctrl-C): the run is a failure.
  s.requestStop();
  ASSERT_TRUE(pollUntil(s, [&] { return s.finished(); }));
  EXPECT_EQ(s.processes()[1].state, ProcessState::kStopped);
  EXPECT_TRUE(s.anyFailed());
}

TEST(HealthLaunch, EndsSpreadBeyondTheWindowAreNoCrashLoop) {
  Supervisor s(
      {shell("rare", "exit 1")},
      SupervisorOptions{.backoff = {.initial_s = 0.05, .max_s = 0.05, .stable_s = 60},
                        .stop_grace_s = 0.3,
                        .crash_loop = {.restarts = 3, .window_s = 0.08}},
      [](const ProcessRecord&, std::string_view) {}, [](const std::string&) {});
  s.startAll();
  ASSERT_TRUE(pollUntil(s, [&] { return s.processes()[0].restarts >= 5; }));
  EXPECT_FALSE(s.processes()[0].crash_loop);
  EXPECT_FALSE(s.anyFailed());
}

TEST(HealthLaunch, PreflightRunsEveryChildWithCheckArgs) {
  std::vector<LaunchInstance> instances{
      shell("good", "test \"$0\" = --check-args && exit 0; exit 9"),
      shell("typo", "echo 'The following argument was not expected: --feild' >&2; exit 2"),
      shell("starts", "exec sleep 30"),  // ignores --check-args and runs
      shell("odd", "exit 7")};
  instances[1].robot = 2;
  const std::vector<std::string> problems =
      checkArguments(instances, PreflightOptions{.timeout_s = 0.5, .parallel = 4});
  ASSERT_EQ(problems.size(), 3U) << (problems.empty() ? "" : problems[0]);
  EXPECT_TRUE(contains(problems,
                       "r2 typo: arguments rejected (exit code 2): The following "
                       "argument was not expected: --feild"));
  EXPECT_TRUE(contains(problems, "r1 starts: no answer to --check-args"));
  EXPECT_TRUE(contains(problems, "r1 odd: --check-args ended with exit code 7"));
  EXPECT_FALSE(contains(problems, "good"));
}

TEST(HealthLaunch, AnExecutableTypoIsAnErrorNamingTheClosestBuiltOne) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("fieldline_health_launch_bin_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto camera = dir / "fieldline-camera";
  std::ofstream(camera) << "#!/bin/sh\nexit 0\n";
  std::filesystem::permissions(camera, std::filesystem::perms::owner_all);

  LaunchFile file;
  file.path = "team.yaml";
  ProcessEntry typo{.name = "camera", .executable = "fieldline-camrea", .line = 7};
  typo.robots = {1, 2};
  ProcessEntry optional{.name = "extra", .executable = "fieldline-not-yet", .optional = true};
  optional.robots = {1};
  file.processes = {typo, optional};
  const LaunchPlan plan = planLaunch(file, 2, [&](const std::string& executable) {
    return findExecutable(executable, dir.string(), nullptr);
  });
  const std::vector<std::string> problems = checkExecutables(file, plan, dir.string());
  // Before: a warning, and the team ran without cameras. One problem per entry, not per robot.
  ASSERT_EQ(problems.size(), 1U);
  EXPECT_NE(problems[0].find("team.yaml:7: process camera: executable fieldline-camrea not found"),
            std::string::npos)
      << problems[0];
  EXPECT_NE(problems[0].find("(did you mean fieldline-camera?)"), std::string::npos) << problems[0];
  std::filesystem::remove_all(dir);
}

}  // namespace health_launch_test
}  // namespace fieldline::launch
