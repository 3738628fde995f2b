// Issue 34, red-team finding 4: the pilot steered on guesses. After fusion restarted, its first
// ROBOT_STATE was SEARCHING at the field's twin 7.35 m away and the pilot turned at full rate
// towards it; after any stall it sprinted at about twice its speed to catch up with its
// trajectory clock.
//
// Run against main at 6957b54 (before the fix) all three failed: the pilot kept sending commands
// (100 in 2 s) steering on the SEARCHING twin, with its state ok, and on a twin-ambiguous twin;
// after a 3 s stall it commanded 1.54 m/s on a 0.8 m/s figure eight (1.9 times its speed).
#include <cmath>
#include <memory>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "common/robot/robot_params.hpp"
#include "common/scenario/scenario.hpp"
#include "services/pilot/pilot_node.hpp"

namespace fieldline::pilot {
namespace redteam_pilot_test {

constexpr Utime kT0 = 1'800'000'000'000'000;

class redteam_pilot_guesses : public ::testing::Test {
 protected:
  redteam_pilot_guesses() {
    listener.subscribe(bus::channels::kMotionCommand,
                       [this](const motion_command_t& m) { commands.push_back(m); });
  }
  void tick() {
    clock.advance(20'000);
    for (int i = 0; i < 3; ++i) {
      pilot_node.spinOnce(0);
      listener.spinOnce(0);
    }
  }
  void publishState(const geometry::Pose2& p, std::int8_t status) {
    robot_state_t s{};
    s.header.utime = clock.now();
    s.x = p.x;
    s.y = p.y;
    s.phi = p.phi;
    s.status = status;
    fusion.publish(bus::channels::kRobotState, s);
  }

  scenario::Scenario scenario = scenario::loadScenarioPreset("default");
  robot::RobotParams params = robot::loadRobotPreset("fu2004");
  SimulatedClock clock{kT0};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node pilot_node{{.process = "pilot", .robot_id = 2, .status_period_us = 0}, clock, memq};
  bus::Node fusion{{.process = "fusion", .robot_id = 2, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 2, .status_period_us = 0}, clock, memq};
  std::vector<motion_command_t> commands;
};

// Fusion restarted: SEARCHING at the twin of where the robot is. The pilot holds (sends nothing,
// the bridge stops the robot) and says why; it drives again on TRACKING.
TEST_F(redteam_pilot_guesses, ASearchingPoseIsNotSteeredWith) {
  PilotNode node(pilot_node, Pilot(scenario, 2, params), {.steer = SteerBy::kState});
  const geometry::Pose2 start = scenario.robotById(2)->start;
  for (int i = 0; i < 50; ++i) {
    publishState(start, robot_state_t::STATUS_TRACKING);
    tick();
  }
  const std::size_t driving = commands.size();
  EXPECT_GE(driving, 45u);
  const geometry::Pose2 twin{-start.x, -start.y, start.phi + std::numbers::pi};
  for (int i = 0; i < 100; ++i) {
    publishState(twin, robot_state_t::STATUS_SEARCHING);
    tick();
  }
  EXPECT_EQ(commands.size(), driving);  // main: 100 more, steering towards the twin
  const service_status_t s = pilot_node.status().takeStatus(clock.now());
  EXPECT_EQ(s.state, service_status_t::STATE_WARN);
  EXPECT_NE(s.state_reason.find("SEARCHING"), std::string::npos) << s.state_reason;
  publishState(start, robot_state_t::STATUS_TRACKING);
  tick();
  EXPECT_EQ(commands.size(), driving + 1);
}

// A twin-ambiguous TRACKING pose at the twin of the trajectory is not steered with either; one
// where the trajectory has the robot is (every robot starts ambiguous until teammates see the
// ball).
TEST_F(redteam_pilot_guesses, ATwinAmbiguousPoseIsUsedOnlyWhereTheTrajectoryHasTheRobot) {
  PilotNode node(pilot_node, Pilot(scenario, 2, params), {.steer = SteerBy::kState});
  const geometry::Pose2 start = scenario.robotById(2)->start;
  auto ambiguous = [&](const geometry::Pose2& p) {
    robot_state_t s{};
    s.header.utime = clock.now();
    s.x = p.x;
    s.y = p.y;
    s.phi = p.phi;
    s.status = robot_state_t::STATUS_TRACKING;
    s.twin_ambiguous = true;
    fusion.publish(bus::channels::kRobotState, s);
  };
  ambiguous(start);
  tick();
  EXPECT_EQ(commands.size(), 1u);
  ambiguous({-start.x, -start.y, start.phi + std::numbers::pi});
  tick();
  EXPECT_EQ(commands.size(), 1u);
}

// After a 3 s stall (no pose to steer with, the robot stopped), the trajectory waits for the
// robot: the pilot goes on at the scripted speed instead of sprinting after its clock.
TEST(redteam_pilot_sprint, AfterAStallTheRobotGoesOnAtItsSpeed) {
  const auto scenario = scenario::loadScenarioPreset("default");
  const auto params = robot::loadRobotPreset("fu2004");
  Pilot pilot(scenario, 1, params);  // the figure eight at 0.8 m/s
  Utime now = kT0;
  // Perfect following for 5 s: the robot is where the pilot's reference is.
  for (int k = 0; k < 250; ++k, now += 20'000) {
    const auto ref = pilot.reference(now);
    pilot.onPose(ref ? ref->pose : scenario.robotById(1)->start, now);
    ASSERT_TRUE(pilot.command(now));
  }
  const geometry::Pose2 stopped = pilot.reference(now)->pose;
  // The stall: nothing for 3 s (fusion, the machine), the robot stands where it was.
  for (int k = 0; k < 150; ++k, now += 20'000)
    (void)pilot.command(now);
  double fastest = 0.0;
  for (int k = 0; k < 50; ++k, now += 20'000) {
    pilot.onPose(stopped, now);
    const auto cmd = pilot.command(now);
    ASSERT_TRUE(cmd);
    fastest = std::max(fastest, std::hypot(cmd->vx, cmd->vy) * params.max_speed);
  }
  EXPECT_LE(fastest, 1.25 * 0.8 + 1e-9);  // main: 1.54 m/s
}

}  // namespace redteam_pilot_test
}  // namespace fieldline::pilot
