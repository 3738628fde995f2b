// Issue 13 finding 10: after the simulator restarts, its scenario used to start again from t = 0
// and every robot jumped back to its start pose. Now the world is snapshotted to a state file
// and a restart continues from it (a clean stop writes a last one: issue 34), a snapshot that
// is too old or of another scenario is not resumed. (The kill -9 of the real process:
// health_world_sim_resumes_after_kill.)
#include <filesystem>
#include <memory>

#include <unistd.h>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/scenario/scenario.hpp"
#include "common/time/clock.hpp"
#include "services/world_sim/world.hpp"
#include "services/world_sim/world_sim_node.hpp"
#include "services/world_sim/world_snapshot.hpp"

namespace fieldline::world_sim {
namespace health_world_test {

namespace fs = std::filesystem;

World drivenWorld(const scenario::Scenario& scenario, int steps) {
  World w(scenario);
  for (int i = 0; i < steps; ++i) {
    w.setWheelCommands(0, Eigen::Vector3d(0.6, -0.6, 0.1));
    w.step();
  }
  return w;
}

TEST(HealthWorld, SnapshotRoundTripsAndRestoreContinuesTheSameWorld) {
  const auto scenario = scenario::loadScenarioPreset("default");
  const World a = drivenWorld(scenario, 600);
  WorldSnapshot s = a.snapshot();
  s.saved_utime = 1'800'000'000'000'000;
  const WorldSnapshot decoded = decodeSnapshot(encodeSnapshot(s));
  EXPECT_EQ(encodeSnapshot(decoded), encodeSnapshot(s));  // every double bit for bit

  World b(scenario);
  b.restore(decoded);
  EXPECT_EQ(b.steps(), a.steps());
  EXPECT_DOUBLE_EQ(b.time(), a.time());
  EXPECT_EQ(b.robots()[0].pose.x, a.robots()[0].pose.x);
  EXPECT_EQ(b.robots()[0].pose.y, a.robots()[0].pose.y);
  EXPECT_EQ(b.ticks(0), a.ticks(0));  // odometry goes on without a jump
  EXPECT_EQ(b.ball().position, a.ball().position);
  // Robot 1 is not at its start pose (what a restart from t = 0 gave).
  EXPECT_GT((b.robots()[0].pose.position() - scenario.robots[0].start.position()).norm(), 0.3);

  WorldSnapshot other = decoded;
  other.scenario = "another";
  EXPECT_THROW(b.restore(other), std::invalid_argument);
  other = decoded;
  other.robots.pop_back();
  EXPECT_THROW(b.restore(other), std::invalid_argument);
  EXPECT_THROW(decodeSnapshot("hello\n"), std::runtime_error);
  EXPECT_THROW(decodeSnapshot(encodeSnapshot(s).substr(0, 60)), std::runtime_error);
}

class HealthWorldNode : public ::testing::Test {
 protected:
  struct Sim {
    std::unique_ptr<bus::Node> node;
    std::unique_ptr<WorldSimNode> sim;
  };
  void SetUp() override {
    tmp_dir = fs::temp_directory_path() / ("fieldline-health-world-" + std::to_string(::getpid()));
    fs::create_directories(tmp_dir);
  }
  void TearDown() override { fs::remove_all(tmp_dir); }

  Sim start(const std::string& pty, WorldSimNodeOptions options = {}) {
    options.pty_dir = (tmp_dir / pty).string();
    options.state_file = state();
    Sim s;
    s.node = std::make_unique<bus::Node>(
        bus::NodeOptions{.process = "world_sim", .robot_id = 0, .status_period_us = 0}, sim_clock,
        memq);
    s.sim = std::make_unique<WorldSimNode>(*s.node, world_scenario, options);
    return s;
  }
  void run(Sim& s, double seconds) {
    for (int i = 0; i < static_cast<int>(seconds * 200 + 0.5); ++i) {
      sim_clock.advance(5'000);
      s.node->spinOnce(0);
    }
  }
  // What a kill -9 leaves: the last snapshot of the timer (a clean stop writes one more, issue
  // 34 finding 3).
  void crash(Sim& s) {
    s.sim->writeSnapshot();
    fs::copy_file(state(), state() + ".kept");
    s.sim.reset();
    EXPECT_TRUE(fs::exists(state())) << "a clean stop keeps the state file";
    fs::rename(state() + ".kept", state(), ec);
  }
  std::error_code ec;
  std::string state() const { return (tmp_dir / "world_sim.state").string(); }

  fs::path tmp_dir;
  scenario::Scenario world_scenario = scenario::loadScenarioPreset("default");
  SimulatedClock sim_clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
};

TEST_F(HealthWorldNode, ARestartAfterACrashContinuesTheWorld) {
  Sim first = start("a");
  EXPECT_FALSE(first.sim->resumed());
  run(first, 1.5);
  EXPECT_TRUE(fs::exists(state()));  // written by its timer
  const double t = first.sim->world().time();
  crash(first);

  sim_clock.advance(300'000);  // the launcher's restart
  Sim second = start("b");
  EXPECT_TRUE(second.sim->resumed());
  EXPECT_NEAR(second.sim->world().time(), t, 1e-9);  // before: 0
  // Simulated time goes on from there, stamped after everything the first one published.
  EXPECT_GT(second.sim->utimeAt(second.sim->world().time()), first.node->now() - 300'000);
  run(second, 0.5);
  EXPECT_NEAR(second.sim->world().time(), t + 0.5, 0.01);
}

TEST_F(HealthWorldNode, OldForeignOrUnwantedSnapshotsStartAfresh) {
  Sim first = start("a");
  run(first, 1.0);
  crash(first);
  sim_clock.advance(6'000'000);  // longer than resume_within_s (5 s)
  Sim late = start("b");
  EXPECT_FALSE(late.sim->resumed());
  EXPECT_DOUBLE_EQ(late.sim->world().time(), 0.0);
  crash(late);

  Sim fresh = start("c", {.fresh = true});
  EXPECT_FALSE(fresh.sim->resumed());
  crash(fresh);

  world_scenario.name = "renamed";
  Sim other = start("d");
  EXPECT_FALSE(other.sim->resumed());
}

}  // namespace health_world_test
}  // namespace fieldline::world_sim
