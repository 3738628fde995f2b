// The bridge's logic: command checks, zero on silence, odometry from the firmware emulator's
// frames with physical time stamps, and malformed bytes counted but never forwarded.
#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "common/robot/omni_kinematics.hpp"
#include "services/motor_bridge/bridge.hpp"
#include "services/world_sim/firmware.hpp"

namespace fieldline::motor_bridge {
namespace bridge_test {

namespace proto = serial;
constexpr Utime kT0 = 1'700'000'000'000'000;

proto::VelocityCommand decodeCommand(const std::vector<std::uint8_t>& frame) {
  proto::Decoder d;
  std::vector<proto::Message> out;
  d.feed(frame, out);
  EXPECT_EQ(out.size(), 1u);
  return std::get<proto::VelocityCommand>(out.at(0));
}

TEST(Bridge, CommandsAreCheckedClampedAndExpire) {
  BridgeCore bridge(robot::loadRobotPreset("fu2004"));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(bridge.onCommand({nan, 0.0, 0.0, kT0 + 100'000}, kT0));
  EXPECT_EQ(bridge.counters().at("command_nan"), 1u);
  EXPECT_FALSE(bridge.onCommand({0.5, 0.0, 0.0, kT0 - 1}, kT0));
  EXPECT_EQ(bridge.counters().at("command_expired"), 1u);
  // Nothing valid yet: zero goes out.
  EXPECT_EQ(decodeCommand(bridge.commandFrame(kT0)).vx_q15, 0);

  EXPECT_TRUE(bridge.onCommand({1.7, -0.5, 0.25, kT0 + 100'000}, kT0));
  EXPECT_EQ(bridge.counters().at("command_clamped"), 1u);
  const auto sent = decodeCommand(bridge.commandFrame(kT0 + 20'000));
  EXPECT_EQ(sent.vx_q15, 32767);
  EXPECT_EQ(sent.vy_q15, proto::toQ15(-0.5));
  EXPECT_EQ(sent.omega_q15, proto::toQ15(0.25));
  EXPECT_TRUE(bridge.commandActive(kT0 + 100'000));
  // The source stopped: past the deadline the robot is told to stand still.
  const auto after = decodeCommand(bridge.commandFrame(kT0 + 100'001));
  EXPECT_EQ(after.vx_q15, 0);
  EXPECT_EQ(after.omega_q15, 0);
  EXPECT_GT(after.seq, sent.seq);
  EXPECT_EQ(bridge.counters().at("command_timeout"), 1u);
}

TEST(Bridge, OdometryFromTheEmulatorIsStampedWithThePhysicalTime) {
  const auto params = robot::loadRobotPreset("fu2004");
  BridgeCore bridge(params);
  world_sim::FirmwareEmulator firmware(params, 123'000);
  std::vector<std::uint8_t> wire;
  std::vector<OdometryOutput> out;

  // Hello both ways.
  firmware.receive(bridge.helloFrame(), 0.0, wire);
  bridge.onBytes(wire, kT0, out);
  ASSERT_TRUE(bridge.controllerHello().has_value());
  EXPECT_EQ(bridge.controllerHello()->ticks_per_revolution, 768);
  EXPECT_TRUE(out.empty());

  wire.clear();
  firmware.sample(0.02, {0, 0, 0}, wire);
  bridge.onBytes(wire, kT0 + 20'000, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, kT0 + 20'000 - 8'000);  // minus the controller latency
  EXPECT_TRUE(out[0].status & perception::kOdometryResync);
  EXPECT_TRUE(out[0].status & perception::kOdometryWatchdog);  // no command yet
  EXPECT_EQ(out[0].controller_utime, 123'000 + 20'000);

  // 100 ticks on the side wheels against each other: forward.
  wire.clear();
  firmware.sample(0.04, {100, -100, 0}, wire);
  bridge.onBytes(wire, kT0 + 40'000, out);
  ASSERT_EQ(out.size(), 2u);
  robot::WheelOdometry reference(params);
  const auto expected = reference.movement({100, -100, 0});
  EXPECT_NEAR(out[1].movement.dx, expected.dx, 1e-12);
  EXPECT_GT(out[1].movement.dx, 0.0);
  EXPECT_NEAR(out[1].vx, expected.dx / 0.02, 1e-9);
  EXPECT_EQ(out[1].status & perception::kOdometryResync, 0);

  // A lost sample is flagged, the movement still covers both intervals.
  wire.clear();
  firmware.sample(0.06, {200, -200, 0}, wire);
  wire.clear();
  firmware.sample(0.08, {300, -300, 0}, wire);
  bridge.onBytes(wire, kT0 + 80'000, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_TRUE(out[2].status & perception::kOdometryFramesLost);
  EXPECT_EQ(bridge.samplesLost(), 1u);
  EXPECT_NEAR(out[2].movement.dx, reference.movement({200, -200, 0}).dx, 1e-12);
}

TEST(Bridge, WheelCurrentsAreForwardedInAmperes) {
  const auto params = robot::loadRobotPreset("fu2004");
  BridgeCore bridge(params);
  std::vector<OdometryOutput> out;
  serial::OdometrySample s;
  s.seq = 0;
  s.controller_time_us = 1'000;
  bridge.onBytes(serial::encode(s), kT0, out);  // no currents
  s.seq = 1;
  s.controller_time_us = 21'000;
  s.current_ma = serial::PerWheel<std::int16_t>{1500, -250, 0};
  bridge.onBytes(serial::encode(s), kT0 + 20'000, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].status & perception::kOdometryCurrents, 0);
  EXPECT_TRUE(out[1].status & perception::kOdometryCurrents);
  EXPECT_FLOAT_EQ(out[1].wheel_current[0], 1.5f);
  EXPECT_FLOAT_EQ(out[1].wheel_current[1], -0.25f);
  EXPECT_FLOAT_EQ(out[1].wheel_current[2], 0.0f);
}

TEST(Bridge, TheGyroAngleBecomesTheRotationSinceThePreviousSampleAcrossWrapAndLoss) {
  const auto params = robot::loadRobotPreset("fu2004");
  BridgeCore bridge(params);
  std::vector<OdometryOutput> out;
  serial::OdometrySample s;
  const auto send = [&](std::uint32_t seq, std::optional<std::int32_t> angle) {
    s.seq = seq;
    s.controller_time_us = 1'000 + 20'000ULL * seq;
    s.gyro_angle_urad = angle;
    bridge.onBytes(serial::encode(s), kT0 + 20'000 * seq, out);
  };
  const std::int32_t near_max = std::numeric_limits<std::int32_t>::max() - 1'000;
  send(0, near_max);                                        // the first sample: no difference yet
  send(1, std::numeric_limits<std::int32_t>::min() + 999);  // +2000 µrad across the wrap
  send(3, std::numeric_limits<std::int32_t>::min() + 499);  // sample 2 lost: -500 µrad over both
  send(4, {});                                              // a sample without the tail
  send(5, 12);                                              // no reference: no difference
  send(6, 10);
  ASSERT_EQ(out.size(), 6u);
  EXPECT_EQ(out[0].status & perception::kOdometryGyro, 0);
  EXPECT_TRUE(out[1].status & perception::kOdometryGyro);
  EXPECT_NEAR(out[1].gyro_dphi, 2000e-6, 1e-12);
  EXPECT_TRUE(out[2].status & perception::kOdometryFramesLost);
  EXPECT_NEAR(out[2].gyro_dphi, -500e-6, 1e-12);
  EXPECT_EQ(out[3].status & perception::kOdometryGyro, 0);
  EXPECT_EQ(out[3].gyro_dphi, 0.0);
  EXPECT_EQ(out[4].status & perception::kOdometryGyro, 0);
  EXPECT_TRUE(out[5].status & perception::kOdometryGyro);
  EXPECT_NEAR(out[5].gyro_dphi, -2e-6, 1e-12);
}

TEST(Bridge, TheEmulatedGyroSeesATurnTheWheelsDoNotShow) {
  auto params = robot::loadRobotPreset("fu2004");
  ASSERT_TRUE(params.gyro.present);
  // An ideal gyro apart from its quantisation, to compare with the true angle.
  params.gyro.noise_density = params.gyro.bias_sigma = params.gyro.bias_walk = 0.0;
  params.gyro.scale_sigma = 0.0;
  BridgeCore bridge(params);
  world_sim::FirmwareEmulator firmware(params, 5'000);
  std::vector<std::uint8_t> wire;
  std::vector<OdometryOutput> out;
  double t = 0.0;
  const double dt = 0.0025;
  for (int sample = 1; sample <= 3; ++sample) {
    for (int k = 0; k < 8; ++k) {
      firmware.gyroStep(sample == 1 ? 0.0 : 2.0, dt);  // twisted at 2 rad/s, wheels still
      t += dt;
    }
    wire.clear();
    firmware.sample(t, {0, 0, 0}, wire);
    bridge.onBytes(wire, kT0 + static_cast<Utime>(std::llround(t * 1e6)), out);
  }
  ASSERT_EQ(out.size(), 3u);
  for (std::size_t i = 1; i < 3; ++i) {
    EXPECT_TRUE(out[i].status & perception::kOdometryGyro);
    EXPECT_EQ(out[i].movement.dphi, 0.0);
    // 2 rad/s for 20 ms, to the LSB's and the microradian's rounding.
    EXPECT_NEAR(out[i].gyro_dphi, 0.04, params.gyro.lsb * 0.02 + 2e-6);
  }
}

TEST(Bridge, MalformedFramesAreCountedNeverForwarded) {
  const auto params = robot::loadRobotPreset("fu2004");
  BridgeCore bridge(params);
  world_sim::FirmwareEmulator firmware(params, 0);
  std::vector<std::uint8_t> good;
  firmware.sample(0.02, {1, 2, 3}, good);
  std::vector<std::uint8_t> wire = good;
  wire[3] ^= 0x10;                              // a bit flip: fails the CRC
  wire.insert(wire.end(), {0x33, 0x44, 0x00});  // garbage
  std::vector<OdometryOutput> out;
  bridge.onBytes(wire, kT0, out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(bridge.decoderStats().badFrames(), 2u);
  EXPECT_EQ(
      bridge.counters().at("serial_crc") + bridge.counters().at("serial_cobs") +
          (bridge.counters().count("serial_length") ? bridge.counters().at("serial_length") : 0),
      2u);
  // The next intact frame gets through.
  bridge.onBytes(good, kT0 + 1, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].ticks[2], 3);
}

TEST(Bridge, ConfigAndDeviceNames) {
  const auto c =
      loadBridgeConfig(config::Node::loadFile(config::resolvePreset("robot", "motor_bridge")));
  EXPECT_EQ(deviceForRobot(c.device, 4), "/tmp/fieldline/robot4.tty");
  EXPECT_DOUBLE_EQ(c.command_rate, 50.0);
  EXPECT_THROW(
      loadBridgeConfig(config::Node::loadString("device: x\nbaud_rate: 9600\n"
                                                "reconnect_interval: 1\ncommand_rate: 0\n")),
      config::Error);
}

}  // namespace bridge_test
}  // namespace fieldline::motor_bridge

namespace fieldline::motor_bridge {
namespace bridge_test {

class BridgeHostile : public ::testing::Test {
 protected:
  robot::RobotParams params = robot::loadRobotPreset("fu2004");
  BridgeCore bridge{params};
  world_sim::FirmwareEmulator firmware{params, 5'000'000};
  std::vector<OdometryOutput> out;

  // A sample of the emulator at controller time t (s) with these ticks, received at `now`.
  void sample(double t, robot::TickCounts ticks, Utime now) {
    std::vector<std::uint8_t> wire;
    firmware.sample(t, ticks, wire);
    bridge.onBytes(wire, now, out);
  }
};

TEST_F(BridgeHostile, AFarDeadlineIsCutToTheMaximumLifetime) {
  EXPECT_TRUE(bridge.onCommand({0.5, 0.0, 0.0, kT0 + 3'600'000'000}, kT0));
  EXPECT_EQ(bridge.counters().at("command_deadline_clamped"), 1u);
  EXPECT_TRUE(bridge.commandActive(kT0 + BridgeCore::kMaxCommandLifetimeUs));
  EXPECT_FALSE(bridge.commandActive(kT0 + BridgeCore::kMaxCommandLifetimeUs + 1));
  EXPECT_EQ(decodeCommand(bridge.commandFrame(kT0 + 600'000)).vx_q15, 0);
}

TEST_F(BridgeHostile, ADuplicateSampleIsDropped) {
  std::vector<std::uint8_t> wire;
  firmware.sample(0.02, {0, 0, 0}, wire);
  bridge.onBytes(wire, kT0, out);
  bridge.onBytes(wire, kT0 + 1000, out);  // the same frame again
  EXPECT_EQ(out.size(), 1u);
  EXPECT_EQ(bridge.counters().at("odometry_duplicate"), 1u);
  EXPECT_EQ(bridge.samplesLost(), 0u);
}

TEST_F(BridgeHostile, AControllerRestartWithoutItsResetFlagIsAResyncNotAJump) {
  sample(0.02, {0, 0, 0}, kT0);
  sample(0.04, {5000, -5000, 0}, kT0 + 20'000);  // fast, but within the motors' reach
  ASSERT_EQ(out.size(), 2u);
  // The controller restarted (new emulator: seq and clock start again, ticks from zero) and its
  // first sample, the one with the reset flag, was lost on the line.
  world_sim::FirmwareEmulator restarted(params, 0);
  std::vector<std::uint8_t> lost, wire;
  restarted.sample(0.02, {0, 0, 0}, lost);
  restarted.sample(0.04, {10, -10, 0}, wire);
  bridge.onBytes(wire, kT0 + 60'000, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_TRUE(out[2].status & perception::kOdometryResync);
  EXPECT_DOUBLE_EQ(out[2].movement.dx, 0.0);
  EXPECT_DOUBLE_EQ(out[2].movement.dphi, 0.0);
  EXPECT_EQ(bridge.counters().at("odometry_discontinuity"), 1u);
  EXPECT_EQ(bridge.samplesLost(), 0u);
}

TEST_F(BridgeHostile, ImpossibleWheelSpeedsAreNotPublishedAsMovement) {
  sample(0.02, {0, 0, 0}, kT0);
  // 100 wheel turns in 20 ms.
  sample(0.04, {76800, -76800, 0}, kT0 + 20'000);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(bridge.counters().at("odometry_implausible"), 1u);
  EXPECT_DOUBLE_EQ(out[1].movement.dx, 0.0);
  EXPECT_TRUE(out[1].status & perception::kOdometryResync);
  // The next sample continues from the new reference.
  sample(0.06, {76810, -76810, 0}, kT0 + 40'000);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_GT(out[2].movement.dx, 0.0);
  EXPECT_LT(out[2].movement.dx, 0.01);
}

TEST_F(BridgeHostile, SamplesReadTogetherKeepTheirOwnTimes) {
  std::vector<std::uint8_t> wire;
  firmware.sample(0.02, {0, 0, 0}, wire);
  firmware.sample(0.04, {10, -10, 0}, wire);
  firmware.sample(0.06, {20, -20, 0}, wire);
  bridge.onBytes(wire, kT0, out);  // the bridge was busy: three samples in one read
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[2].utime, kT0 - 8'000);
  EXPECT_EQ(out[1].utime, kT0 - 8'000 - 20'000);
  EXPECT_EQ(out[0].utime, kT0 - 8'000 - 40'000);
}

TEST_F(BridgeHostile, TheLinksJitterStaysOutOfTheStamps) {
  // Samples every 20 ms of the controller's clock, each read 0-7 ms late (a busy host, the
  // line's buffering): the stamps are the controller's 20 ms apart once the fastest read was seen
  // (the low envelope of receive - controller time), not the jittered read times.
  const Utime latency = static_cast<Utime>(std::llround(params.controller_latency * 1e6));
  const Utime late[] = {5'000, 0, 7'000, 2'000, 6'000, 1'000, 3'000};
  for (int k = 0; k < 60; ++k) {
    const Utime taken = kT0 + 20'000 * k;
    sample(0.02 * (k + 1), {k, -k, 0}, taken + latency + late[k % 7]);
  }
  ASSERT_EQ(out.size(), 60u);
  for (std::size_t k = 8; k < out.size(); ++k) {
    EXPECT_EQ(out[k].utime - out[k - 1].utime, 20'000) << k;
    EXPECT_EQ(out[k].utime, kT0 + 20'000 * static_cast<Utime>(k)) << k;
  }
  EXPECT_EQ(bridge.clockRestarts(), 0u);
}

TEST_F(BridgeHostile, AReplayedOldFrameDoesNotRestartTheClockMapping) {
  // A replaying line delivers an old frame among the good ones: the bridge resyncs on it (its
  // checks), the clock mapping starts over without counting a controller restart, and the good
  // samples after it keep their physical times.
  const Utime latency = static_cast<Utime>(std::llround(params.controller_latency * 1e6));
  std::vector<std::uint8_t> old_frame;
  for (int k = 0; k < 10; ++k) {
    std::vector<std::uint8_t> wire;
    firmware.sample(0.02 * (k + 1), {k, -k, 0}, wire);
    if (k == 2) old_frame = wire;
    bridge.onBytes(wire, kT0 + 20'000 * k + latency, out);
  }
  bridge.onBytes(old_frame, kT0 + 20'000 * 10 + latency, out);
  for (int k = 10; k < 15; ++k)
    sample(0.02 * (k + 1), {k, -k, 0}, kT0 + 20'000 * k + latency);
  EXPECT_EQ(bridge.clockRestarts(), 0u);
  EXPECT_GE(bridge.counters().at("odometry_discontinuity"), 1u);
  ASSERT_EQ(out.size(), 16u);
  for (std::size_t i = 11; i < out.size(); ++i)
    EXPECT_EQ(out[i].utime, kT0 + 20'000 * static_cast<Utime>(i - 1)) << i;
}

TEST_F(BridgeHostile, AReconnectStartsTheClockMappingOver) {
  sample(0.02, {0, 0, 0}, kT0);
  ASSERT_TRUE(bridge.clockOffset().has_value());
  bridge.onConnected();
  EXPECT_FALSE(bridge.clockOffset().has_value());
  EXPECT_EQ(bridge.clockRestarts(), 0u);
}

TEST_F(BridgeHostile, AnImplausibleControllerTimeIsRefusedBeforeTheClockMapping) {
  // CRC-valid, but 2^63 µs would overflow the signed clock arithmetic.
  serial::OdometrySample bad;
  bad.seq = 1;
  bad.controller_time_us = std::uint64_t{1} << 63;
  std::vector<std::uint8_t> wire{serial::kDelimiter};
  serial::encode(bad, wire);
  bridge.onBytes(wire, kT0, out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(bridge.counters().at("odometry_controller_time_absurd"), 1u);
  EXPECT_FALSE(bridge.clockOffset().has_value());
  sample(0.02, {0, 0, 0}, kT0 + 20'000);  // the next good sample goes through
  ASSERT_EQ(out.size(), 1u);
}

}  // namespace bridge_test
}  // namespace fieldline::motor_bridge

namespace fieldline::motor_bridge {
namespace bridge_test {

TEST(Bridge, FourWheelsFromTheEmulatorBecomeMovementAndAWrongCountIsRefused) {
  const auto params = robot::loadRobotPreset("four_wheel");
  BridgeCore bridge(params);
  world_sim::FirmwareEmulator firmware(params, 1'000'000);
  std::vector<OdometryOutput> out;
  // 2 cm to the left in 20 ms (1 m/s): each wheel's ticks from the kinematics.
  const robot::OmniKinematics k(params.wheels);
  const robot::WheelVector rotation = k.wheelAngularSpeeds({0.0, 0.02, 0.0});
  robot::TickCounts start{100, 200, 300, 400};
  robot::TickCounts next = start;
  for (std::size_t i = 0; i < 4; ++i)
    next[i] += static_cast<std::int32_t>(
        std::lround(rotation[static_cast<Eigen::Index>(i)] * params.ticksPerWheelRevolution() /
                    (2.0 * std::numbers::pi)));
  std::vector<std::uint8_t> wire;
  firmware.sample(0.02, start, wire);
  firmware.sample(0.04, next, wire);
  bridge.onBytes(wire, kT0, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].ticks.size(), 4u);
  EXPECT_EQ(out[1].ticks[3], next[3]);
  const double tick_m = 2.0 * std::numbers::pi * 0.04 / 768.0;
  EXPECT_NEAR(out[1].movement.dy, 0.02, tick_m);
  EXPECT_NEAR(out[1].movement.dx, 0.0, tick_m);
  EXPECT_NEAR(out[1].vy, 1.0, tick_m / 0.02);

  // A three-wheeled robot's bridge on this controller: every sample refused and counted.
  BridgeCore three(robot::loadRobotPreset("fu2004"));
  std::vector<OdometryOutput> none;
  three.onBytes(wire, kT0, none);
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(three.counters().at("odometry_wheel_count_mismatch"), 2u);
}

}  // namespace bridge_test
}  // namespace fieldline::motor_bridge
