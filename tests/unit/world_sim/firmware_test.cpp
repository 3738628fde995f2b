// The firmware emulator: latency, watchdog, odometry frames, Hello; and its pseudo-terminal.
#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "services/world_sim/firmware.hpp"
#include "services/world_sim/pseudo_terminal.hpp"

namespace fieldline::world_sim {
namespace firmware_test {

namespace proto = serial;

std::vector<proto::Message> decode(const std::vector<std::uint8_t>& bytes) {
  proto::Decoder d;
  std::vector<proto::Message> out;
  d.feed(bytes, out);
  return out;
}

TEST(Firmware, CommandsActAfterTheLatencyAndTheWatchdogStopsThem) {
  const auto params = robot::loadRobotPreset("fu2004");
  FirmwareEmulator fw(params, 5'000'000);
  std::vector<std::uint8_t> reply;
  EXPECT_TRUE(fw.watchdogStopped(0.0));
  fw.receive(proto::encode(proto::VelocityCommand{1, proto::toQ15(0.5), 0, proto::toQ15(-0.25)}),
             1.0, reply);
  EXPECT_TRUE(reply.empty());
  EXPECT_DOUBLE_EQ(fw.motorCommand(1.0 + 0.007).vx, 0.0);  // still on its way (8 ms)
  const auto active = fw.motorCommand(1.0 + 0.009);
  EXPECT_NEAR(active.vx, 0.5, 1e-4);
  EXPECT_NEAR(active.omega, -0.25, 1e-4);
  EXPECT_NEAR(fw.motorCommand(1.19).vx, 0.5, 1e-4);
  EXPECT_FALSE(fw.watchdogStopped(1.19));
  EXPECT_DOUBLE_EQ(fw.motorCommand(1.201).vx, 0.0);  // 200 ms without a command
  EXPECT_TRUE(fw.watchdogStopped(1.201));
  EXPECT_EQ(fw.stats().watchdog_stops, 1u);
}

TEST(Firmware, CurrentsAreTheAccelerationAndTheFrictionOfTheSlip) {
  const auto params = robot::loadRobotPreset("fu2004");
  const CurrentModel model{
      .enabled = true, .friction_coefficient = 0.5, .saturation_slip_speed = 1.0, .noise_a = 0.0};
  // Amperes per newton at the wheel: radius / (gear * torque constant).
  const double per_newton =
      params.wheels[0].radius / (params.gear_ratio * params.motor.torque_constant);
  const double share = params.mass / 3.0;
  const double limit = 0.5 * share * 9.81;
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  WheelState before{zero, zero};
  WheelState after{zero, zero};
  after.speeds = Eigen::Vector3d(0.1, -0.1, 0.0);  // +-5 m/s^2 over 20 ms
  robot::WheelVector amps =
      FirmwareEmulator::wheelCurrents(params, model, before, after, 0.02, zero);
  EXPECT_NEAR(amps[0], share * 5.0 * per_newton, 1e-9);
  EXPECT_NEAR(amps[1], -share * 5.0 * per_newton, 1e-9);
  EXPECT_NEAR(amps[2], 0.0, 1e-12);
  // Slipping: half the limit at half the saturation speed, the limit beyond it, either sign.
  after.speeds = zero;
  after.slip = Eigen::Vector3d(0.01, 0.1, -0.1);  // 0.5, 5, -5 m/s over 20 ms
  amps = FirmwareEmulator::wheelCurrents(params, model, before, after, 0.02, zero);
  EXPECT_NEAR(amps[0], 0.5 * limit * per_newton, 1e-9);
  EXPECT_NEAR(amps[1], limit * per_newton, 1e-9);
  EXPECT_NEAR(amps[2], -limit * per_newton, 1e-9);
  // Noise adds noise_a per unit.
  CurrentModel noisy = model;
  noisy.noise_a = 0.05;
  const Eigen::Vector3d unit(1.0, -2.0, 0.0);
  const robot::WheelVector with_noise =
      FirmwareEmulator::wheelCurrents(params, noisy, before, after, 0.02, unit);
  EXPECT_NEAR(with_noise[0] - amps[0], 0.05, 1e-12);
  EXPECT_NEAR(with_noise[1] - amps[1], -0.1, 1e-12);

  // In frames: none in the first sample (no period yet), then mA in every one; off: none.
  FirmwareEmulator fw(params, 5'000'000, noisy);
  std::vector<std::uint8_t> out;
  WheelState wheels{zero, zero};
  fw.sample(0.02, {0, 0, 0}, out, &wheels);
  wheels.slip = Eigen::Vector3d(0.1, 0.0, 0.0);
  fw.sample(0.04, {0, 0, 0}, out, &wheels);
  FirmwareEmulator off(params, 5'000'000, CurrentModel{.enabled = false});
  off.sample(0.02, {0, 0, 0}, out, &wheels);
  off.sample(0.04, {0, 0, 0}, out, &wheels);
  const auto msgs = decode(out);
  ASSERT_EQ(msgs.size(), 4u);
  EXPECT_FALSE(std::get<proto::OdometrySample>(msgs[0]).current_ma);
  const auto second = std::get<proto::OdometrySample>(msgs[1]).current_ma;
  ASSERT_TRUE(second);
  EXPECT_NEAR((*second)[0] * 1e-3, limit * per_newton, 0.3);  // 1.71 A, noise 0.05 A
  EXPECT_NEAR((*second)[1] * 1e-3, 0.0, 0.3);
  EXPECT_FALSE(std::get<proto::OdometrySample>(msgs[2]).current_ma);
  EXPECT_FALSE(std::get<proto::OdometrySample>(msgs[3]).current_ma);
}

TEST(Firmware, SamplesCarryTicksClockStatusAndTheLastCommand) {
  const auto params = robot::loadRobotPreset("fu2004");
  FirmwareEmulator fw(params, 5'000'000);
  std::vector<std::uint8_t> out;
  fw.sample(0.02, {1, -2, 3}, out);
  std::vector<std::uint8_t> reply;
  fw.receive(proto::encode(proto::VelocityCommand{42, 0, 0, 0}), 0.03, reply);
  const std::vector<std::uint8_t> broken{0x05, 0x11, 0x00};
  fw.receive(broken, 0.031, reply);  // a broken frame: reported
  fw.sample(0.04, {10, -20, 30}, out);
  const auto msgs = decode(out);
  ASSERT_EQ(msgs.size(), 2u);
  const auto a = std::get<proto::OdometrySample>(msgs[0]);
  const auto b = std::get<proto::OdometrySample>(msgs[1]);
  EXPECT_EQ(a.seq, 0u);
  EXPECT_EQ(b.seq, 1u);
  EXPECT_EQ(a.controller_time_us, 5'020'000u);
  EXPECT_EQ(b.ticks, (serial::PerWheel<std::int32_t>{10, -20, 30}));
  EXPECT_TRUE(a.status & proto::kStatusReset);
  EXPECT_TRUE(a.status & proto::kStatusWatchdog);
  EXPECT_FALSE(b.status & proto::kStatusWatchdog);
  EXPECT_TRUE(b.status & proto::kStatusRxErrors);
  EXPECT_EQ(b.last_command_seq, 42u);
  const auto errors = decode(reply);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(std::get<proto::ErrorReport>(errors[0]).code, proto::ErrorCode::kBadFrame);
}

TEST(Firmware, FourWheelsSendTheirTicksAndCurrentsAsType0x21) {
  const auto params = robot::loadRobotPreset("four_wheel");
  const CurrentModel model{.enabled = true, .noise_a = 0.0};
  // Each wheel carries a quarter of the mass.
  const double per_newton =
      params.wheels[0].radius / (params.gear_ratio * params.motor.torque_constant);
  const robot::WheelVector zero = robot::WheelVector::Zero(4);
  WheelState before{zero, zero};
  WheelState after{zero, zero};
  after.speeds << 0.1, -0.1, 0.0, 0.1;
  const robot::WheelVector amps =
      FirmwareEmulator::wheelCurrents(params, model, before, after, 0.02, zero);
  ASSERT_EQ(amps.size(), 4);
  EXPECT_NEAR(amps[3], params.mass / 4.0 * 5.0 * per_newton, 1e-9);
  // Three wheel states for four wheels: refused.
  const Eigen::Vector3d three = Eigen::Vector3d::Zero();
  EXPECT_THROW(FirmwareEmulator::wheelCurrents(params, model, WheelState{three, three},
                                               WheelState{three, three}, 0.02, zero),
               std::invalid_argument);

  FirmwareEmulator fw(params, 1'000'000, model);
  std::vector<std::uint8_t> out;
  fw.sample(0.02, {1, 2, 3, 4}, out, &before);
  fw.sample(0.04, {5, 6, 7, 8}, out, &after);
  // COBS: a code byte, then the payload's version and type (neither is zero).
  ASSERT_GE(out.size(), 3u);
  EXPECT_EQ(out[2], 0x21);
  const auto msgs = decode(out);
  ASSERT_EQ(msgs.size(), 2u);
  const auto b = std::get<proto::OdometrySample>(msgs[1]);
  EXPECT_EQ(b.ticks, (serial::PerWheel<std::int32_t>{5, 6, 7, 8}));
  ASSERT_TRUE(b.current_ma);
  EXPECT_EQ(b.current_ma->size(), 4u);
  EXPECT_NEAR((*b.current_ma)[3] * 1e-3, amps[3], 1e-3);
}

TEST(Gyro, BiasAndScaleOfAStartFollowTheirSpreadAndStayPut) {
  const auto params = robot::loadRobotPreset("fu2004").gyro;
  ASSERT_TRUE(params.present);
  // Over many starts (seeds) the drawn biases and scale errors have the configured spread.
  double bias2 = 0.0, scale2 = 0.0;
  const int starts = 2000;
  for (int i = 0; i < starts; ++i) {
    const GyroModel g(params, 1000 + static_cast<std::uint64_t>(i));
    bias2 += g.bias() * g.bias();
    scale2 += g.scaleError() * g.scaleError();
  }
  EXPECT_NEAR(std::sqrt(bias2 / starts), params.bias_sigma, 0.1 * params.bias_sigma);
  EXPECT_NEAR(std::sqrt(scale2 / starts), params.scale_sigma, 0.1 * params.scale_sigma);

  // One start standing still for 60 s: the mean rate is the bias (it walks only a little: the
  // walk over 60 s is bias_walk * sqrt(60) one sigma), and the angle grows by it.
  GyroModel g(params, 77);
  const double bias0 = g.bias();
  const double dt = 0.0025;
  for (int k = 0; k < 24'000; ++k)
    g.step(0.0, dt);
  const double walk = params.bias_walk * std::sqrt(60.0);
  EXPECT_NEAR(g.angle() / 60.0, bias0, 4.0 * walk + 1e-5);
  EXPECT_NEAR(g.bias(), bias0, 5.0 * walk);
  EXPECT_EQ(g.saturated(), 0u);
  EXPECT_EQ(g.samples(), 24'000u);
}

TEST(Gyro, WhiteNoiseIntegratesToItsAngleRandomWalk) {
  auto params = robot::loadRobotPreset("fu2004").gyro;
  params.bias_sigma = params.bias_walk = params.scale_sigma = 0.0;
  params.lsb = 0.0;
  params.noise_density = 0.01;  // large, so that the test measures it quickly
  // Increments over 20 ms periods of 8 rate samples at 400 Hz: each rate sample has the density
  // times sqrt(bandwidth) (200 Hz) of noise, so a period's angle has that times 2.5 ms * sqrt(8).
  GyroModel g(params, 5);
  const int periods = 5000;
  double sum2 = 0.0, previous = 0.0;
  for (int p = 0; p < periods; ++p) {
    for (int k = 0; k < 8; ++k)
      g.step(0.0, 0.0025);
    const double d = g.angle() - previous;
    previous = g.angle();
    sum2 += d * d;
  }
  const double expected = 0.01 * std::sqrt(200.0) * 0.0025 * std::sqrt(8.0);
  EXPECT_NEAR(std::sqrt(sum2 / periods), expected, 0.05 * expected);
}

TEST(Gyro, ScaleErrorSaturationAndQuantisation) {
  auto params = robot::loadRobotPreset("fu2004").gyro;
  params.noise_density = params.bias_sigma = params.bias_walk = 0.0;
  params.scale_sigma = 0.01;
  GyroModel g(params, 11);
  const double scale = g.scaleError();
  ASSERT_NE(scale, 0.0);
  // 3 rad/s for 1 s: the angle is off by the scale error (to the LSB's rounding).
  for (int k = 0; k < 400; ++k)
    g.step(3.0, 0.0025);
  EXPECT_NEAR(g.angle(), 3.0 * (1.0 + scale), 0.5 * params.lsb);
  // Every rate sample is a whole number of LSBs: the angle over one sample is too.
  const double before = g.angle();
  g.step(0.123456, 0.0025);
  const double lsbs = (g.angle() - before) / 0.0025 / params.lsb;
  EXPECT_NEAR(lsbs, std::round(lsbs), 1e-6);
  // Beyond the range the rate saturates and is counted: a 0.5 rad jump within one 2.5 ms step
  // (200 rad/s) gives at most range * dt.
  const double at = g.angle();
  g.step(200.0, 0.0025);
  EXPECT_EQ(g.saturated(), 1u);
  EXPECT_NEAR(g.angle() - at, params.range * 0.0025, params.lsb * 0.0025);
  g.step(-200.0, 0.0025);
  EXPECT_EQ(g.saturated(), 2u);
  EXPECT_NEAR(g.angle(), at, 2.0 * params.lsb * 0.0025);
}

TEST(Firmware, SamplesCarryTheGyroAngleOnlyWhenTheRobotHasOne) {
  auto params = robot::loadRobotPreset("fu2004");
  FirmwareEmulator with(params, 1'000);
  params.gyro.present = false;
  FirmwareEmulator without(params, 1'000);
  std::vector<std::uint8_t> a, b;
  for (int k = 0; k < 8; ++k) {
    with.gyroStep(1.0, 0.0025);
    without.gyroStep(1.0, 0.0025);
  }
  with.sample(0.02, {0, 0, 0}, a);
  without.sample(0.02, {0, 0, 0}, b);
  const auto sa = std::get<proto::OdometrySample>(decode(a).at(0));
  const auto sb = std::get<proto::OdometrySample>(decode(b).at(0));
  ASSERT_TRUE(sa.gyro_angle_urad);
  EXPECT_NEAR(*sa.gyro_angle_urad * 1e-6, with.gyro()->angle(), 1e-6);
  EXPECT_NEAR(*sa.gyro_angle_urad * 1e-6, 0.02, 0.02 * 0.03 + 0.001);  // 1 rad/s for 20 ms
  EXPECT_FALSE(sb.gyro_angle_urad);
  EXPECT_FALSE(without.gyro());
}

TEST(Firmware, AnswersAHostHello) {
  FirmwareEmulator fw(robot::loadRobotPreset("fu2004"), 0);
  std::vector<std::uint8_t> reply;
  fw.receive(proto::encode(proto::Hello{proto::Role::kHost, 1, 0, 0}), 0.0, reply);
  const auto msgs = decode(reply);
  ASSERT_EQ(msgs.size(), 1u);
  const auto hello = std::get<proto::Hello>(msgs[0]);
  EXPECT_EQ(hello.role, proto::Role::kController);
  EXPECT_EQ(hello.ticks_per_revolution, 768);
  EXPECT_EQ(hello.odometry_period_us, 20000u);
}

TEST(PseudoTerminal, BytesTravelBothWaysThroughTheLink) {
  const std::string link = (std::filesystem::temp_directory_path() /
                            ("fieldline-test-" + std::to_string(getpid())) / "robot1.tty")
                               .string();
  std::string slave;
  {
    PseudoTerminal pty(link);
    ASSERT_TRUE(std::filesystem::is_symlink(link));
    slave = pty.slavePath();
    const int fd = ::open(link.c_str(), O_RDWR | O_NOCTTY);
    ASSERT_GE(fd, 0);
    const std::vector<std::uint8_t> down{0x00, 0x01, 0x0a, 0x0d, 0xff};
    EXPECT_EQ(pty.write(down), 0u);
    std::uint8_t buf[16];
    ASSERT_EQ(::read(fd, buf, sizeof buf), 5);  // raw: no CR/LF translation
    EXPECT_TRUE(std::equal(down.begin(), down.end(), buf));
    const std::uint8_t up[3] = {0x0d, 0x00, 0x03};
    ASSERT_EQ(::write(fd, up, 3), 3);
    std::vector<std::uint8_t> got;
    for (int tries = 0; tries < 1000 && got.size() < 3; ++tries)
      pty.read(got);
    EXPECT_EQ(got, (std::vector<std::uint8_t>{0x0d, 0x00, 0x03}));
    ::close(fd);
  }
  EXPECT_FALSE(std::filesystem::exists(link));  // the device disappeared
  std::filesystem::remove_all(std::filesystem::path(link).parent_path());
}

}  // namespace firmware_test
}  // namespace fieldline::world_sim
