// The example text-line adapter as a process would run it (docs/own-controller.md): the node over
// memq:// with a simulated clock, a fake four-wheeled controller behind a real pseudo-terminal
// writing "O t_us ticks..." lines and reading "V vx vy omega" lines, and the real fusion node on
// the ODOMETRY the adapter publishes: fusion takes every sample (no refusal), its velocity is the
// driven one, and with line frames it tracks the robot to within a few centimetres.
#include "services/motor_bridge/text_bridge_node.hpp"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/msg/line_contours.hpp"
#include "common/robot/omni_kinematics.hpp"
#include "services/fusion/fusion_node.hpp"
#include "services/world_sim/pseudo_terminal.hpp"
#include "tests/unit/fusion/test_world.hpp"

namespace fieldline::motor_bridge {
namespace text_bridge_node_test {

class TextBridgeNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() /
          ("fieldline-text-bridge-" + std::to_string(::getpid()));
    config.device = (dir / "robot1.tty").string();
    config.reconnect_interval = 0.01;
    config.command_rate = 50.0;
    pty = std::make_unique<world_sim::PseudoTerminal>(config.device);
  }
  void TearDown() override {
    pty.reset();
    std::filesystem::remove_all(dir);
  }

  void spin() {
    for (int k = 0; k < 4; ++k) {
      bridge_bus.spinOnce(1);
      fusion_bus.spinOnce(0);
      listener.spinOnce(0);
    }
  }
  // What the adapter wrote to the controller so far.
  std::string readLine() {
    std::vector<std::uint8_t> bytes;
    pty->read(bytes);
    return {bytes.begin(), bytes.end()};
  }

  std::filesystem::path dir;
  BridgeConfig config;
  std::unique_ptr<world_sim::PseudoTerminal> pty;
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node bridge_bus{
      {.process = "text_bridge", .robot_id = 1, .status_period_us = 0}, clock, memq};
  bus::Node fusion_bus{{.process = "fusion", .robot_id = 1, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 1, .status_period_us = 0}, clock, memq};
  robot::RobotParams params = robot::loadRobotPreset("four_wheel");
};

TEST_F(TextBridgeNodeTest, FusionTracksAFourWheeledRobotOnTheAdaptersOdometry) {
  TextBridgeNode bridge(bridge_bus, params, config);
  bridge.start();
  ASSERT_TRUE(bridge.link().connected());
  fusion::FusionNodeOptions options;
  options.robot = params;
  fusion::FusionNode fusion(fusion_bus, options, fusion::test_support::world().functions());

  std::vector<odometry_t> odometry;
  std::vector<robot_state_t> states;
  listener.subscribe(bus::channels::kOdometry, [&](const odometry_t& m) { odometry.push_back(m); });
  listener.subscribe(bus::channels::kRobotState,
                     [&](const robot_state_t& m) { states.push_back(m); });

  // A command reaches the controller as a V line in SI units.
  motion_command_t command{};
  command.header.utime = clock.now();
  command.vx = 0.2;
  command.omega = 0.05;
  command.deadline_utime = clock.now() + 200'000;
  listener.publish(bus::channels::kMotionCommand, command);

  // The fake controller: the robot drives a curve at 0.7 m/s; the controller integrates each
  // wheel and reports its accumulated ticks at 50 Hz, each line read 8 ms after its sample (the
  // robot file's controller_latency) with up to 3 ms of jitter.
  const robot::OmniKinematics kinematics(params.wheels);
  const robot::Twist twist{0.7, 0.0, 0.35};
  geometry::Pose2 truth{-2.5, 1.0, 0.3};
  std::vector<double> rotation(4, 0.0);
  std::int64_t controller_us = 7'000'000;
  std::mt19937 rng(9);
  std::string received;
  const auto tickLine = [&] {
    std::string line = fmt::format("O {}", controller_us);
    for (const double r : rotation)
      line += fmt::format(
          " {}", static_cast<std::int64_t>(std::floor(r * 768.0 / (2.0 * std::numbers::pi))));
    return line + "\n";
  };
  const Utime latency = 8'000;
  const Utime start = clock.now();
  for (int k = 0; k < 200; ++k) {
    const double dt = 0.02;
    const robot::WheelVector w = kinematics.wheelAngularSpeeds(twist) * dt;
    for (std::size_t i = 0; i < 4; ++i)
      rotation[i] += w[static_cast<Eigen::Index>(i)];
    truth = geometry::applyMovement(
        truth, robot::arcMovement(Eigen::Vector3d(twist.vx, twist.vy, twist.omega) * dt));
    controller_us += 20'000;
    const Utime sampled = start + (k + 1) * 20'000;
    clock.set(sampled);
    spin();  // the command timer and the fusion's own timers run in between
    clock.set(sampled + latency + (k % 4) * 1'000);
    const std::string line = tickLine();
    pty->write(std::span(reinterpret_cast<const std::uint8_t*>(line.data()), line.size()));
    // Bounded: a broken adapter fails the test instead of hanging it.
    for (int round = 0; round < 500 && odometry.size() < static_cast<std::size_t>(k + 1); ++round)
      spin();
    received += readLine();
    // A line frame of the field as the robot sees it at the sample's time, every 100 ms.
    if (k % 5 == 0) {
      line_contours_t m{};
      perception::LinePoints points;
      points.points = fusion::test_support::world().view(truth, rng);
      points.sequences.push_back({0, static_cast<int>(points.points.size())});
      msg::toMessage(points, m);
      m.header.utime = sampled;
      listener.publish(bus::channels::kVisionLines, m);
      spin();
    }
  }

  EXPECT_NE(received.find(fmt::format("V {:.4f} 0.0000 {:.4f}\n", 0.2 * params.max_speed,
                                      0.05 * params.max_omega)),
            std::string::npos)
      << received.substr(0, 200);
  EXPECT_NE(received.find("V 0.0000 0.0000 0.0000\n"), std::string::npos);  // after the deadline

  ASSERT_EQ(odometry.size(), 200u);
  for (const odometry_t& o : odometry) {
    EXPECT_EQ(o.wheel_count, 4);
    ASSERT_EQ(o.ticks.size(), 4u);
  }
  // Stamped at the sampling time, whatever the jitter of the line.
  EXPECT_EQ(odometry[150].header.utime - odometry[149].header.utime, 20'000);
  // Fusion took every sample: no refusal for the odometry but the first sample's resync (the
  // adapter's STATUS_RESYNC: it only sets fusion's reference).
  for (const auto& [reason, n] : fusion.localizer().counters().rejected) {
    if (reason == "odometry_resync") {
      EXPECT_EQ(n, 1u);
    } else {
      EXPECT_EQ(reason.find("odometry"), std::string::npos) << reason << " " << n;
    }
  }
  EXPECT_EQ(fusion_bus.status().errorCount("odometry_wheel_count"), 0);
  ASSERT_GE(states.size(), 190u);
  const robot_state_t& last = states.back();
  EXPECT_EQ(last.status, robot_state_t::STATUS_TRACKING);
  EXPECT_LT(std::hypot(last.x - truth.x, last.y - truth.y), 0.05);
  EXPECT_LT(std::abs(geometry::angleDiff(last.phi, truth.phi)), 0.03);
  // The velocity fusion reports is the driven one (robot frame: forward and turning).
  const geometry::Vec2 body = geometry::rotate(geometry::Vec2(last.vx, last.vy), -last.phi);
  EXPECT_NEAR(body.x(), twist.vx, 0.05);
  EXPECT_NEAR(body.y(), twist.vy, 0.05);
  EXPECT_NEAR(last.omega, twist.omega, 0.05);
}

TEST_F(TextBridgeNodeTest, GarbageOnTheLineIsAnErrorInTheStatus) {
  TextBridgeNode bridge(bridge_bus, params, config);
  bridge.start();
  const std::string junk = "O 1000 1 2 3\nOK\n";
  pty->write(std::span(reinterpret_cast<const std::uint8_t*>(junk.data()), junk.size()));
  std::vector<odometry_t> odometry;
  listener.subscribe(bus::channels::kOdometry, [&](const odometry_t& m) { odometry.push_back(m); });
  for (int k = 0; k < 60; ++k) {
    clock.advance(20'000);
    spin();
  }
  EXPECT_TRUE(odometry.empty());
  EXPECT_EQ(bridge.core().counters().at("text_wheel_count"), 1u);
  EXPECT_EQ(bridge.core().counters().at("text_malformed"), 1u);
  EXPECT_GE(bridge_bus.status().errorCount("text_bad_lines"), 1);
}

}  // namespace text_bridge_node_test
}  // namespace fieldline::motor_bridge
