// The pilot node over memq:// with a simulated clock: steering by SIM_WORLD truth or by the
// robot's own ROBOT_STATE, MOTION_COMMAND at the command rate with its deadline, and silence
// without a fresh pose (or with a pose fusion does not stand behind).
#include "services/pilot/pilot_node.hpp"

#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "common/msg/world_state.hpp"
#include "common/robot/robot_params.hpp"
#include "common/scenario/scenario.hpp"

namespace fieldline::pilot {
namespace {

class PilotNodeTest : public ::testing::Test {
 protected:
  PilotNodeTest() {
    listener_.subscribe(bus::channels::kMotionCommand,
                        [this](const motion_command_t& m) { commands_.push_back(m); });
  }
  Pilot makePilot() {
    // Robot 3 of the default scenario rotates in place at 1 rad/s.
    return Pilot(scenario_, 3, params_);
  }
  // One command period: the clock moves 20 ms, everyone handles what arrived.
  void tick() {
    clock_.advance(20'000);
    for (int i = 0; i < 3; ++i) {
      pilot_node_.spinOnce(0);
      listener_.spinOnce(0);
    }
  }
  void publishTruth() {
    perception::WorldTruth truth;
    truth.utime = clock_.now();
    truth.robots.push_back({.id = 1, .pose = {1.0, 1.0, 0.0}});
    truth.robots.push_back({.id = 3, .pose = scenario_.robotById(3)->start});
    world_state_t w{};
    msg::toMessage(truth, w);
    world_.publish(bus::channels::kSimWorld, w);
  }
  void publishState(std::int8_t status) {
    robot_state_t s{};
    s.header.utime = clock_.now();
    const auto start = scenario_.robotById(3)->start;
    s.x = start.x;
    s.y = start.y;
    s.phi = start.phi;
    s.status = status;
    fusion_.publish(bus::channels::kRobotState, s);
  }

  scenario::Scenario scenario_ = scenario::loadScenarioPreset("default");
  robot::RobotParams params_ = robot::loadRobotPreset("fu2004");
  SimulatedClock clock_{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq_ = bus::Connection::open("memq://");
  bus::Node pilot_node_{{.process = "pilot", .robot_id = 3, .status_period_us = 0}, clock_, memq_};
  bus::Node world_{{.process = "world_sim", .robot_id = 0, .status_period_us = 0}, clock_, memq_};
  bus::Node fusion_{{.process = "fusion", .robot_id = 3, .status_period_us = 0}, clock_, memq_};
  bus::Node listener_{{.process = "listener", .robot_id = 3, .status_period_us = 0}, clock_, memq_};
  std::vector<motion_command_t> commands_;
};

TEST_F(PilotNodeTest, SteersByTruthAndGoesQuietWithoutIt) {
  PilotNode node(pilot_node_, makePilot(), {.steer = SteerBy::kTruth, .command_lifetime = 0.1});
  for (int i = 0; i < 5; ++i)
    tick();
  EXPECT_TRUE(commands_.empty());  // no pose yet: silence, the bridge lets the robot stop

  publishTruth();
  tick();
  ASSERT_EQ(commands_.size(), 1u);
  const auto& c = commands_.back();
  EXPECT_EQ(c.header.utime, clock_.now());
  EXPECT_EQ(c.deadline_utime, clock_.now() + 100'000);
  EXPECT_EQ(c.source, motion_command_t::SOURCE_PILOT);
  EXPECT_NEAR(c.omega, 1.0 / params_.max_omega, 0.05);
  EXPECT_NEAR(c.vx, 0.0, 0.05);

  // The truth stops coming: after max_pose_age (0.3 s) the pilot stops talking.
  for (int i = 0; i < 20; ++i)
    tick();
  const std::size_t sent = commands_.size();
  EXPECT_GE(sent, 10u);
  EXPECT_LE(sent, 17u);
  tick();
  EXPECT_EQ(commands_.size(), sent);
  EXPECT_EQ(node.commandsSent(), static_cast<std::int64_t>(sent));
}

TEST_F(PilotNodeTest, SteersByOwnStateOnlyWhenFusionKnowsThePose) {
  PilotNode node(pilot_node_, makePilot(), {.steer = SteerBy::kState});
  publishState(robot_state_t::STATUS_UNKNOWN);
  tick();
  tick();
  EXPECT_TRUE(commands_.empty());
  publishTruth();  // not listened to in this mode
  tick();
  EXPECT_TRUE(commands_.empty());

  publishState(robot_state_t::STATUS_TRACKING);
  tick();
  ASSERT_EQ(commands_.size(), 1u);
  EXPECT_NEAR(commands_.back().omega, 1.0 / params_.max_omega, 0.05);
}

TEST_F(PilotNodeTest, RefusesABadRate) {
  EXPECT_THROW(PilotNode(pilot_node_, makePilot(), {.rate = 0.0}), std::invalid_argument);
}

}  // namespace
}  // namespace fieldline::pilot
