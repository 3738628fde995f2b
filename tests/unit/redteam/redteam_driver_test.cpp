// Issue 34, red-team finding 1: a second driver went unnoticed. A MOTION_COMMAND publisher on
// robot 1's bus claiming robot 2 (or 0) was obeyed (robot 1 drove 2.1 m/s against a scripted
// 0.78) while the motor bridge said ok: the two-publisher check was kept per robot id and the
// bridge never looked at header.robot_id.
//
// Run against main at 6957b54 (before the fix) both cases failed: the attacker's full-speed
// commands went out on the serial line and the bridge's state stayed ok.
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/serial/protocol.hpp"
#include "services/motor_bridge/bridge_node.hpp"
#include "services/motor_bridge/text_bridge_node.hpp"
#include "services/world_sim/pseudo_terminal.hpp"

namespace fieldline::motor_bridge {
namespace redteam_driver_test {

class redteam_second_driver : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() /
          ("fieldline-redteam-driver-" + std::to_string(::getpid()));
    config.device = (dir / "robot1.tty").string();
    config.reconnect_interval = 0.01;
    config.command_rate = 50.0;
    pty = std::make_unique<world_sim::PseudoTerminal>(config.device);
    if (binary_bridge) {
      bridge = std::make_unique<BridgeNode>(bridge_node, params, config);
      bridge->start();
      ASSERT_TRUE(bridge->link().connected());
    }
  }
  void TearDown() override {
    bridge.reset();
    pty.reset();
    std::filesystem::remove_all(dir);
  }

  static motion_command_t command(Utime now, double vx) {
    motion_command_t c{};
    c.header.utime = now;
    c.vx = vx;
    c.deadline_utime = now + 100'000;
    c.source = motion_command_t::SOURCE_PILOT;
    return c;
  }
  // 2 s of the pilot at 50 Hz (vx 0.39) with `attacker` sending full speed 10 ms after each
  // command, just before the bridge's 50 Hz tick; returns the largest vx the bridge sent to the
  // controller.
  double drive(bus::Node& attacker) {
    int largest = 0;
    for (int k = 0; k < 100; ++k) {
      clock.advance(10'000);
      auto mine = command(clock.now(), 0.39);
      pilot.publish(bus::channels::kMotionCommand, mine);
      bridge_node.spinOnce(0);
      clock.advance(10'000);
      auto theirs = command(clock.now(), 1.0);
      attacker.publish(bus::channels::kMotionCommand, theirs);
      for (int i = 0; i < 3; ++i)
        bridge_node.spinOnce(1);
      std::vector<std::uint8_t> bytes;
      pty->read(bytes);
      std::vector<serial::Message> out;
      decoder.feed(bytes, out);
      for (const auto& m : out) {
        if (const auto* v = std::get_if<serial::VelocityCommand>(&m)) {
          largest = std::max(largest, static_cast<int>(v->vx_q15));
        }
      }
    }
    return static_cast<double>(largest) / serial::toQ15(1.0);
  }

  std::filesystem::path dir;
  BridgeConfig config;
  std::unique_ptr<world_sim::PseudoTerminal> pty;
  serial::Decoder decoder;
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node bridge_node{
      {.process = "motor_bridge", .robot_id = 1, .status_period_us = 0}, clock, memq};
  bus::Node pilot{{.process = "pilot", .robot_id = 1, .status_period_us = 0}, clock, memq};
  robot::RobotParams params = robot::loadRobotPreset("fu2004");
  std::unique_ptr<BridgeNode> bridge;
  // The binary bridge on the line; false for the text bridge's test (both subscribe on the same
  // memq:// bus, so only one may exist).
  bool binary_bridge = true;
};

class redteam_second_driver_text : public redteam_second_driver {
 protected:
  redteam_second_driver_text() { binary_bridge = false; }
};

TEST_F(redteam_second_driver, CommandsClaimingAnotherRobotAreRefusedAndWarned) {
  for (int claimed : {2, 0}) {
    bus::Node attacker{
        {.process = "attacker", .robot_id = claimed, .status_period_us = 0}, clock, memq};
    const double vx = drive(attacker);
    EXPECT_NEAR(vx, 0.39, 0.01) << "robot id " << claimed;
    bridge_node.publishStatus();  // the metrics and the warning are set with it
    const service_status_t s = bridge_node.status().takeStatus(clock.now());
    EXPECT_EQ(s.state, service_status_t::STATE_WARN) << s.state_reason;
    EXPECT_NE(s.state_reason.find("MOTION_COMMAND for robot " + std::to_string(claimed)),
              std::string::npos)
        << s.state_reason;
  }
  EXPECT_EQ(bridge_node.status().errorCount("command_other_robot"), 200);
}

// The same with the attacker claiming robot 1 itself: one publisher drives, the other is refused.
TEST_F(redteam_second_driver, ASecondPublisherForThisRobotIsRefusedWhileTheFirstDrives) {
  bus::Node attacker{{.process = "attacker", .robot_id = 1, .status_period_us = 0}, clock, memq};
  EXPECT_NEAR(drive(attacker), 0.39, 0.01);
  bridge_node.publishStatus();
  const service_status_t s = bridge_node.status().takeStatus(clock.now());
  EXPECT_NE(s.state, service_status_t::STATE_OK);
  EXPECT_NE(s.state_reason.find("MOTION_COMMAND"), std::string::npos) << s.state_reason;
  EXPECT_EQ(bridge_node.status().errorCount("command_second_publisher"), 100);
}

// The example text-line adapter (fieldline-text-bridge) obeys the same rule: a command claiming
// robot 2 on robot 1's bus never reaches the controller's "V vx vy omega" lines.
TEST_F(redteam_second_driver_text, AnotherRobotsCommandsAreRefusedToo) {
  bus::Node text_node{
      {.process = "text_bridge", .robot_id = 1, .status_period_us = 0}, clock, memq};
  TextBridgeNode text_bridge(text_node, params, config);
  text_bridge.start();
  ASSERT_TRUE(text_bridge.link().connected());
  bus::Node attacker{{.process = "attacker", .robot_id = 2, .status_period_us = 0}, clock, memq};
  double fastest = 0.0;
  std::string lines;
  for (int k = 0; k < 50; ++k) {
    clock.advance(10'000);
    auto mine = command(clock.now(), 0.39);
    pilot.publish(bus::channels::kMotionCommand, mine);
    text_node.spinOnce(0);
    clock.advance(10'000);
    auto theirs = command(clock.now(), 1.0);
    attacker.publish(bus::channels::kMotionCommand, theirs);
    for (int i = 0; i < 3; ++i)
      text_node.spinOnce(1);
    std::vector<std::uint8_t> bytes;
    pty->read(bytes);
    lines.append(bytes.begin(), bytes.end());
  }
  std::istringstream in(lines);
  std::string tag;
  double vx = 0.0, vy = 0.0, omega = 0.0;
  int commands = 0;
  while (in >> tag >> vx >> vy >> omega) {
    ASSERT_EQ(tag, "V") << lines.substr(0, 200);
    fastest = std::max(fastest, vx);
    ++commands;
  }
  ASSERT_GT(commands, 0);
  EXPECT_NEAR(fastest, 0.39 * params.max_speed, 0.01) << lines.substr(0, 200);  // main: 1.0 x
  EXPECT_EQ(text_node.status().errorCount("command_other_robot"), 50);
  text_node.publishStatus();
  const service_status_t s = text_node.status().takeStatus(clock.now());
  EXPECT_EQ(s.state, service_status_t::STATE_WARN) << s.state_reason;
  EXPECT_NE(s.state_reason.find("MOTION_COMMAND for robot 2"), std::string::npos) << s.state_reason;
}

// A restarted pilot (a new publisher id) takes over once the old one is silent.
TEST(redteam_second_driver_source, ASilentDriverHandsOver) {
  CommandSource source(1);
  const Utime t0 = 1'800'000'000'000'000;
  EXPECT_EQ(source.onCommand(1, 11, t0).verdict, CommandSource::Verdict::kAccept);
  EXPECT_EQ(source.onCommand(1, 22, t0 + 100'000).verdict,
            CommandSource::Verdict::kSecondPublisher);
  EXPECT_EQ(source.onCommand(1, 22, t0 + 700'000).verdict, CommandSource::Verdict::kAccept);
  EXPECT_EQ(source.driver(), 22);
  EXPECT_EQ(source.onCommand(3, 22, t0 + 720'000).verdict, CommandSource::Verdict::kOtherRobot);
  EXPECT_FALSE(source.warning(t0 + 720'000).empty());
  EXPECT_TRUE(source.warning(t0 + 720'000 + CommandSource::kWarnHoldUs + 1).empty());
}

}  // namespace redteam_driver_test
}  // namespace fieldline::motor_bridge
