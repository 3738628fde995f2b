// The example text-line adapter (docs/own-controller.md): lines parsed and refused with their
// reason, ODOMETRY from "O" lines of a four-wheeled (and three-wheeled) controller with the same
// stamps and movements as the binary bridge, "S" lines of a controller without ticks, garbage
// counted and never forwarded, commands as "V" lines in SI units that stop at the deadline.
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/robot/omni_kinematics.hpp"
#include "services/motor_bridge/text_bridge.hpp"
#include "services/motor_bridge/text_protocol.hpp"

namespace fieldline::motor_bridge {
namespace text_bridge_test {

constexpr Utime kT0 = 1'700'000'000'000'000;

std::span<const std::uint8_t> bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

TEST(TextProtocol, LinesParseOrSayWhatIsWrong) {
  const auto o = text::parseLine("O 123456 10 -20 30 -2147483648");
  ASSERT_TRUE(std::holds_alternative<text::TickLine>(o));
  EXPECT_EQ(std::get<text::TickLine>(o).controller_time_us, 123456);
  EXPECT_EQ(std::get<text::TickLine>(o).ticks.size(), 4u);
  EXPECT_EQ(std::get<text::TickLine>(o).ticks[3], -2147483648);
  const auto s = text::parseLine("S\t5  0.5 -0.25 1e-1");
  ASSERT_TRUE(std::holds_alternative<text::VelocityLine>(s));
  EXPECT_DOUBLE_EQ(std::get<text::VelocityLine>(s).omega, 0.1);
  EXPECT_TRUE(std::holds_alternative<text::Comment>(text::parseLine("# firmware 2.1 ready")));
  for (const char* bad :
       {"", "X 1 2 3", "O", "O 12", "O -5 1 2 3", "O 1 2 3 4 5 6", "O 1 2 3 2147483648",
        "O 1 2 x 3", "S 1 0.5 0.5", "S 1 nan 0 0", "S 1 inf 0 0", "O 1.5 1 2 3"}) {
    const auto r = text::parseLine(bad);
    ASSERT_TRUE(std::holds_alternative<text::LineError>(r)) << bad;
    EXPECT_NE(std::get<text::LineError>(r).what.find(bad), std::string::npos);
  }
  EXPECT_EQ(text::formatCommand(1.25, -0.5, 0.0), "V 1.2500 -0.5000 0.0000\n");
}

TEST(TextProtocol, TheSplitterKeepsLinesWhole) {
  text::LineSplitter splitter;
  std::vector<std::string> lines;
  const auto collect = [&](std::string_view l) { lines.emplace_back(l); };
  splitter.feed("O 1 2 ", collect);
  splitter.feed("3 4\r\nS 5", collect);
  EXPECT_EQ(lines, (std::vector<std::string>{"O 1 2 3 4"}));
  splitter.feed(std::string(300, 'x') + "\n# ok\n", collect);
  EXPECT_EQ(splitter.overlong(), 1u);
  // The partial "S 5" ran into the overlong line and went with it; the comment after survives.
  EXPECT_EQ(lines.back(), "# ok");
}

// A four-wheeled controller as a test stand-in: integrates a body twist exactly and reports the
// accumulated ticks of its wheels, like real firmware would.
struct FakeController {
  robot::RobotParams params;
  robot::OmniKinematics kinematics{params.wheels};
  std::vector<double> rotation;  // rad per wheel since the start
  std::int64_t t_us = 3'000'000;

  explicit FakeController(robot::RobotParams p) : params(std::move(p)) {
    rotation.assign(params.wheels.size(), 0.0);
  }
  std::string drive(const robot::Twist& twist, double dt) {
    const robot::WheelVector w = kinematics.wheelAngularSpeeds(twist) * dt;
    for (std::size_t i = 0; i < rotation.size(); ++i)
      rotation[i] += w[static_cast<Eigen::Index>(i)];
    t_us += std::llround(dt * 1e6);
    return line();
  }
  std::string line() const {
    std::string out = fmt::format("O {}", t_us);
    for (const double r : rotation) {
      const auto ticks = static_cast<std::int64_t>(
          std::floor(r * params.ticksPerWheelRevolution() / (2.0 * std::numbers::pi)));
      out += fmt::format(" {}", static_cast<std::int32_t>(static_cast<std::uint32_t>(ticks)));
    }
    return out + "\n";
  }
};

TEST(TextBridge, FourWheelTicksBecomeStampedMovement) {
  const auto params = robot::loadRobotPreset("four_wheel");
  TextBridgeCore bridge(params);
  FakeController controller(params);
  std::vector<perception::OdometryReading> out;
  const Utime latency = static_cast<Utime>(std::llround(params.controller_latency * 1e6));
  bridge.onBytes(bytes(controller.line()), kT0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].status & perception::kOdometryResync);
  EXPECT_EQ(out[0].utime, kT0 - latency);
  // One second at (0.6, -0.4, 0.8) in 50 Hz samples, each received 8 ms after sampling plus a
  // jitter of up to 6 ms that the stamp must not carry.
  geometry::Pose2 pose;
  for (int k = 1; k <= 50; ++k) {
    const std::string line = controller.drive({0.6, -0.4, 0.8}, 0.02);
    bridge.onBytes(bytes(line), kT0 + k * 20'000 + (k % 4) * 2'000, out);
    ASSERT_EQ(out.size(), static_cast<std::size_t>(k + 1));
    const auto& o = out.back();
    EXPECT_EQ(o.ticks.size(), 4u);
    EXPECT_EQ(o.utime, kT0 + k * 20'000 - latency) << k;
    // One tick on each wheel in 20 ms is 0.016 m/s: the velocity is that exact.
    EXPECT_NEAR(o.vx, 0.6, 0.03);
    pose = geometry::applyMovement(pose, o.movement);
  }
  EXPECT_NEAR(pose.phi, 0.8, 0.002);
  const geometry::Pose2 truth = geometry::applyMovement({}, robot::arcMovement({0.6, -0.4, 0.8}));
  EXPECT_NEAR(pose.x, truth.x, 0.002);
  EXPECT_NEAR(pose.y, truth.y, 0.002);
  EXPECT_TRUE(bridge.counters().empty());
}

TEST(TextBridge, GarbageIsCountedAndNeverForwarded) {
  const auto params = robot::loadRobotPreset("four_wheel");
  TextBridgeCore bridge(params);
  std::vector<perception::OdometryReading> out;
  bridge.onBytes(bytes("O 1000 0 0 0 0\nO 21000 1 2 3\nhello\n# boot\n"), kT0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bridge.counters().at("text_wheel_count"), 1u);
  EXPECT_EQ(bridge.counters().at("text_malformed"), 1u);
  EXPECT_NE(bridge.lastError().find("hello"), std::string::npos);
  bridge.onBytes(bytes(std::string(500, '7') + "\n"), kT0 + 10'000, out);
  EXPECT_EQ(bridge.counters().at("text_overlong"), 1u);
  // 100 wheel turns in 20 ms: not a movement; the next sample goes on from there.
  bridge.onBytes(bytes("O 21000 76800 76800 76800 76800\n"), kT0 + 20'000, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(bridge.counters().at("text_implausible"), 1u);
  EXPECT_DOUBLE_EQ(out[1].movement.dx, 0.0);
  EXPECT_TRUE(out[1].status & perception::kOdometryResync);
  bridge.onBytes(bytes("O 41000 76810 76810 76810 76810\n"), kT0 + 40'000, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_FALSE(out[2].status & perception::kOdometryResync);
  EXPECT_GT(out[2].movement.dphi, 0.0);
  // The same time twice, and a controller clock that runs backwards (a restart): refused, resync.
  bridge.onBytes(bytes("O 41000 76810 76810 76810 76810\n"), kT0 + 45'000, out);
  EXPECT_EQ(bridge.counters().at("text_duplicate"), 1u);
  bridge.onBytes(bytes("O 500 0 0 0 0\n"), kT0 + 60'000, out);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_TRUE(out[3].status & perception::kOdometryResync);
}

TEST(TextBridge, AControllerWithoutTicksSendsItsVelocity) {
  const auto params = robot::loadRobotPreset("fu2004");
  TextBridgeCore bridge(params);
  std::vector<perception::OdometryReading> out;
  bridge.onBytes(bytes("S 0 0.5 0 0\n"), kT0, out);
  bridge.onBytes(bytes("S 20000 0.5 0 0\nS 40000 0.7 0 0\n"), kT0 + 20'000, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_TRUE(out[0].ticks.empty());
  EXPECT_TRUE(out[0].status & perception::kOdometryResync);
  EXPECT_NEAR(out[1].movement.dx, 0.01, 1e-12);
  // The mean of the two velocities over the interval.
  EXPECT_NEAR(out[2].movement.dx, 0.012, 1e-12);
  EXPECT_DOUBLE_EQ(out[2].vx, 0.7);
  // Faster than the robot can go: refused.
  bridge.onBytes(bytes("S 60000 50 0 0\n"), kT0 + 40'000, out);
  EXPECT_EQ(out.size(), 3u);
  EXPECT_EQ(bridge.counters().at("text_implausible"), 1u);
  // Ticks now from a controller that sent velocities: no difference across the switch.
  bridge.onBytes(bytes("O 80000 1 2 3\n"), kT0 + 60'000, out);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_TRUE(out[3].status & perception::kOdometryResync);
  EXPECT_EQ(bridge.counters().at("text_mixed"), 1u);
}

TEST(TextBridge, CommandsGoOutInSiUnitsAndStopAtTheDeadline) {
  const auto params = robot::loadRobotPreset("four_wheel");
  TextBridgeCore bridge(params);
  EXPECT_EQ(bridge.commandLine(kT0), "V 0.0000 0.0000 0.0000\n");
  const double nan = std::nan("");
  EXPECT_FALSE(bridge.onCommand({nan, 0.0, 0.0, kT0 + 100'000}, kT0));
  EXPECT_TRUE(bridge.onCommand({0.5, -1.5, 0.25, kT0 + 100'000}, kT0));
  EXPECT_EQ(bridge.commandLine(kT0 + 20'000),
            fmt::format("V {:.4f} {:.4f} {:.4f}\n", 0.5 * params.max_speed, -params.max_speed,
                        0.25 * params.max_omega));
  EXPECT_EQ(bridge.commandLine(kT0 + 100'001), "V 0.0000 0.0000 0.0000\n");
  EXPECT_EQ(bridge.counters().at("command_nan"), 1u);
  EXPECT_EQ(bridge.counters().at("command_clamped"), 1u);
  EXPECT_EQ(bridge.counters().at("command_timeout"), 1u);
}

}  // namespace text_bridge_test
}  // namespace fieldline::motor_bridge
