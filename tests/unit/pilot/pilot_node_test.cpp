// The pilot node over memq:// with a simulated clock: steering by SIM_WORLD truth or by the
// robot's own ROBOT_STATE, MOTION_COMMAND at the command rate with its deadline, and silence
// without a fresh pose (or with a pose fusion does not stand behind).
#include "services/pilot/pilot_node.hpp"

#include <sched.h>

#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/msg/world_state.hpp"
#include "common/robot/robot_params.hpp"
#include "common/scenario/scenario.hpp"
#include "tests/support/private_network.hpp"

namespace fieldline::pilot {
namespace pilot_node_test {

class PilotNodeTest : public ::testing::Test {
 protected:
  PilotNodeTest() {
    listener.subscribe(bus::channels::kMotionCommand,
                       [this](const motion_command_t& m) { commands.push_back(m); });
  }
  Pilot makePilot() {
    // Robot 3 of the default scenario rotates in place at 1 rad/s.
    return Pilot(scenario, 3, params);
  }
  // One command period: the clock moves 20 ms, everyone handles what arrived.
  void tick() {
    clock.advance(20'000);
    for (int i = 0; i < 3; ++i) {
      pilot_node.spinOnce(0);
      listener.spinOnce(0);
    }
  }
  void publishTruth() {
    perception::WorldTruth truth;
    truth.utime = clock.now();
    truth.robots.push_back({.id = 1, .pose = {1.0, 1.0, 0.0}});
    truth.robots.push_back({.id = 3, .pose = scenario.robotById(3)->start});
    world_state_t w{};
    msg::toMessage(truth, w);
    world.publish(bus::channels::kSimWorld, w);
  }
  void publishState(std::int8_t status) {
    robot_state_t s{};
    s.header.utime = clock.now();
    const auto start = scenario.robotById(3)->start;
    s.x = start.x;
    s.y = start.y;
    s.phi = start.phi;
    s.status = status;
    fusion.publish(bus::channels::kRobotState, s);
  }

  scenario::Scenario scenario = scenario::loadScenarioPreset("default");
  robot::RobotParams params = robot::loadRobotPreset("fu2004");
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node pilot_node{{.process = "pilot", .robot_id = 3, .status_period_us = 0}, clock, memq};
  bus::Node world{{.process = "world_sim", .robot_id = 0, .status_period_us = 0}, clock, memq};
  bus::Node fusion{{.process = "fusion", .robot_id = 3, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 3, .status_period_us = 0}, clock, memq};
  std::vector<motion_command_t> commands;
};

TEST_F(PilotNodeTest, SteersByTruthAndGoesQuietWithoutIt) {
  PilotNode node(pilot_node, makePilot(), {.steer = SteerBy::kTruth, .command_lifetime = 0.1});
  for (int i = 0; i < 5; ++i)
    tick();
  EXPECT_TRUE(commands.empty());  // no pose yet: silence, the bridge lets the robot stop

  publishTruth();
  tick();
  ASSERT_EQ(commands.size(), 1u);
  const auto& c = commands.back();
  EXPECT_EQ(c.header.utime, clock.now());
  EXPECT_EQ(c.deadline_utime, clock.now() + 100'000);
  EXPECT_EQ(c.source, motion_command_t::SOURCE_PILOT);
  EXPECT_NEAR(c.omega, 1.0 / params.max_omega, 0.05);
  EXPECT_NEAR(c.vx, 0.0, 0.05);

  // The truth stops coming: after max_pose_age (0.3 s) the pilot stops talking.
  for (int i = 0; i < 20; ++i)
    tick();
  const std::size_t sent = commands.size();
  EXPECT_GE(sent, 10u);
  EXPECT_LE(sent, 17u);
  tick();
  EXPECT_EQ(commands.size(), sent);
  EXPECT_EQ(node.commandsSent(), static_cast<std::int64_t>(sent));
}

TEST_F(PilotNodeTest, SteersByOwnStateOnlyWhenFusionKnowsThePose) {
  PilotNode node(pilot_node, makePilot(), {.steer = SteerBy::kState});
  publishState(robot_state_t::STATUS_UNKNOWN);
  tick();
  tick();
  EXPECT_TRUE(commands.empty());
  publishTruth();  // not listened to in this mode
  tick();
  EXPECT_TRUE(commands.empty());

  publishState(robot_state_t::STATUS_TRACKING);
  tick();
  ASSERT_EQ(commands.size(), 1u);
  EXPECT_NEAR(commands.back().omega, 1.0 / params.max_omega, 0.05);
}

TEST_F(PilotNodeTest, RefusesABadRate) {
  EXPECT_THROW(PilotNode(pilot_node, makePilot(), {.rate = 0.0}), std::invalid_argument);
}

// Issue 32: over a real udpm bus the pilot does not wake for ROBOT_STATE (its socket for waking
// reads nothing); the pose is read just before the next command, which steers by it.
TEST(PilotNodeUdpm, ThePoseWakesNothingAndIsReadBeforeTheNextCommand) {
  // This test's process only (every case runs in a process of its own).
  if (!test::enterPrivateMulticastNetwork()) {
    GTEST_FAIL() << "needs a private network namespace (root, as scripts/test runs)";
  }
  const std::string url = "udpm://239.255.76.67:7802?ttl=0";
  const scenario::Scenario scenario = scenario::loadScenarioPreset("default");
  const robot::RobotParams params = robot::loadRobotPreset("fu2004");
  SimulatedClock clock{1'800'000'000'000'000};
  bus::Node pilot_node{{.process = "pilot", .robot_id = 3, .url = url}, clock};
  bus::Node fusion{{.process = "fusion", .robot_id = 3, .url = url, .status_period_us = 0}, clock};
  bus::Node listener{{.process = "listener", .robot_id = 3, .url = url, .status_period_us = 0},
                     clock};
  std::vector<motion_command_t> commands;
  listener.subscribe(bus::channels::kMotionCommand,
                     [&](const motion_command_t& m) { commands.push_back(m); });
  PilotNode node(pilot_node, Pilot(scenario, 3, params), {.steer = SteerBy::kState});
  robot_state_t s{};
  s.header.utime = clock.now();
  const auto start = scenario.robotById(3)->start;
  s.x = start.x;
  s.y = start.y;
  s.phi = start.phi;
  s.status = robot_state_t::STATUS_TRACKING;
  fusion.publish(bus::channels::kRobotState, s);
  EXPECT_EQ(pilot_node.spinOnce(50), 0);  // nothing due: asleep, the pose waits
  EXPECT_EQ(pilot_node.busDatagrams(), 0);
  clock.advance(20'000);
  pilot_node.spinOnce(0);
  for (int i = 0; i < 100 && commands.empty(); ++i)
    listener.spinOnce(5);
  ASSERT_EQ(commands.size(), 1u);
  EXPECT_NEAR(commands.back().omega, 1.0 / params.max_omega, 0.05);
  EXPECT_EQ(node.commandsSent(), 1);
}

}  // namespace pilot_node_test
}  // namespace fieldline::pilot
