// Issue 34, red-team finding 3: a clean stop of the simulator reset the world. SIGTERM (or
// systemctl restart) of world_sim removed its snapshot, so the launcher's restart began the
// scenario at t = 0 and the robots jumped 3.3-5.6 m without a log line (kill -9 resumed).
//
// Run against main at 6957b54 (before the fix) both cases that compile there failed: after the
// clean stop the new simulator did not resume (world time 0), and the scenario's end stopped the
// process. The multi-process run with SIGTERM is redteam_world_sim_sigterm_resumes
// (tests/integration/redteam).
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "common/process/supervisor_identity.hpp"
#include "services/world_sim/world_sim_node.hpp"

namespace fieldline::world_sim {
namespace redteam_world_test {

namespace fs = std::filesystem;

class redteam_world_reset : public ::testing::Test {
 protected:
  struct Sim {
    std::unique_ptr<bus::Node> node;
    std::unique_ptr<WorldSimNode> sim;
  };
  void SetUp() override {
    dir = fs::temp_directory_path() / ("fieldline-redteam-world-" + std::to_string(::getpid()));
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  Sim start(const std::string& pty, WorldSimNodeOptions options = {}) {
    options.pty_dir = (dir / pty).string();
    options.state_file = (dir / "world_sim.state").string();
    Sim s;
    s.node = std::make_unique<bus::Node>(
        bus::NodeOptions{.process = "world_sim", .robot_id = 0, .status_period_us = 0}, clock,
        memq);
    s.sim = std::make_unique<WorldSimNode>(*s.node, scenario, options);
    return s;
  }
  void run(Sim& s, double seconds) {
    for (int i = 0; i < static_cast<int>(seconds * 200 + 0.5); ++i) {
      clock.advance(5'000);
      s.node->spinOnce(0);
    }
  }

  fs::path dir;
  scenario::Scenario scenario = scenario::loadScenarioPreset("match");
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
};

// SIGTERM ends node.run() and the simulator's destructor runs: that is the clean stop.
TEST_F(redteam_world_reset, ACleanStopIsResumedByTheRestart) {
  Sim first = start("a");
  run(first, 2.0);
  const double t = first.sim->world().time();
  const auto pose = first.sim->world().robots()[0].pose;
  first.sim.reset();  // the clean stop
  first.node.reset();
  clock.advance(300'000);  // the launcher's restart
  Sim second = start("b");
  EXPECT_TRUE(second.sim->resumed());  // main: false, the world began again at t = 0
  EXPECT_NEAR(second.sim->world().time(), t, 1e-9);
  EXPECT_NEAR(second.sim->world().robots()[0].pose.x, pose.x, 1e-9);
  EXPECT_NEAR(second.sim->world().robots()[0].pose.y, pose.y, 1e-9);
}

// A new run (another supervisor) and --fresh start afresh; the same supervisor resumes.
TEST_F(redteam_world_reset, OnlyTheSameSupervisorResumes) {
  Sim first = start("a", {.supervisor = "pid 10 started 99"});
  run(first, 1.0);
  first.sim.reset();
  clock.advance(300'000);
  Sim other = start("b", {.supervisor = "pid 11 started 100"});
  EXPECT_FALSE(other.sim->resumed());
  other.sim.reset();
  Sim again = start("c", {.supervisor = "pid 11 started 100"});
  EXPECT_TRUE(again.sim->resumed());
  again.sim.reset();
  Sim fresh = start("d", {.fresh = true, .supervisor = "pid 11 started 100"});
  EXPECT_FALSE(fresh.sim->resumed());
}

// The scenario's end used to stop the process, and the launcher's restart began it again.
TEST_F(redteam_world_reset, TheWorldGoesOnAfterTheScenariosEnd) {
  scenario.duration = 1.0;
  Sim s = start("a");
  run(s, 2.0);
  EXPECT_TRUE(s.sim->finished());
  EXPECT_FALSE(s.node->stopRequested());
  EXPECT_GT(s.sim->world().time(), 1.9);
}

TEST(redteam_world_reset_supervisor, TheParentsIdentityIsKnown) {
  const std::string id = process::supervisorIdentity();
  EXPECT_NE(id.find("pid " + std::to_string(::getppid()) + " started "), std::string::npos) << id;
  EXPECT_EQ(id, process::supervisorIdentity());
}

}  // namespace redteam_world_test
}  // namespace fieldline::world_sim
