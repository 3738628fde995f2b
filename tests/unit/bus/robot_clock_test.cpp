// The bus's stamp checks with robots on their own clocks (the simulated team): a robot's node
// checks the simulator's messages against the true time, and gives another robot's messages the
// other-clock tolerance.
#include <cstdlib>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/config/config.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline::bus {
namespace robot_clock_test {

constexpr Utime kT0 = 1'800'000'000'000'000;

motion_command_t command(Utime utime) {
  motion_command_t m{};
  m.header.utime = utime;
  m.deadline_utime = utime + 100'000;
  m.source = motion_command_t::SOURCE_PILOT;
  return m;
}

TEST(BusRobotClocks, SimulatorOnTheTruthOtherRobotsWithinTheirTolerance) {
  SimulatedClock truth(kT0);
  // Robot 1 runs 0.8 s behind the truth; robot 2 1.2 s and robot 3 2.5 s ahead of robot 1.
  OffsetClock r1(truth, -800'000, 0.0, kT0);
  OffsetClock r2(truth, 400'000, 0.0, kT0);
  OffsetClock r3(truth, 1'700'000, 0.0, kT0);
  auto memq = Connection::open("memq://");
  Node receiver({.process = "fusion", .robot_id = 1, .status_period_us = 0}, r1, memq);
  Node sim({.process = "world_sim", .robot_id = 0, .status_period_us = 0}, truth, memq);
  Node two({.process = "teamcomm", .robot_id = 2, .status_period_us = 0}, r2, memq);
  Node three({.process = "teamcomm", .robot_id = 3, .status_period_us = 0}, r3, memq);
  Node own({.process = "pilot", .robot_id = 1, .status_period_us = 0}, r1, memq);
  std::vector<int> from;
  receiver.subscribe(channels::kMotionCommand,
                     [&](const motion_command_t& m) { from.push_back(m.header.robot_id); });
  // The simulator's stamp is 0.8 s ahead of robot 1's clock, but it is the truth of robot 1's now.
  auto m1 = command(truth.now());
  sim.publish(channels::kMotionCommand, m1);
  auto m2 = command(r2.now());
  two.publish(channels::kMotionCommand, m2);
  auto m3 = command(r3.now());
  three.publish(channels::kMotionCommand, m3);
  auto m4 = command(r1.now());
  own.publish(channels::kMotionCommand, m4);
  // Robot 1's own process with robot 2's stamp: our robot, our clock, 1.2 s ahead: refused.
  auto m5 = command(r2.now());
  own.publish(channels::kMotionCommand, m5);
  for (int i = 0; i < 10; ++i)
    receiver.spinOnce(0);
  EXPECT_EQ(from, (std::vector<int>{0, 2, 1}));
  EXPECT_EQ(receiver.status().errorCount("future_utime"), 2);
}

TEST(BusRobotClocks, EnvironmentGivesEveryProcessTheSameClock) {
  setenv(kClockOffsetVariable, "250000", 1);
  setenv(kClockDriftVariable, "40", 1);
  setenv(kClockReferenceVariable, "1700000000000000", 1);
  const RobotClock a = robotClockFromEnvironment();
  const RobotClock b = robotClockFromEnvironment();
  EXPECT_EQ(a.error().offset_us, 250'000);
  EXPECT_EQ(b.error().drift_ppm, 40.0);
  SystemClock system;
  const Utime t = a.now();
  // 250 ms plus 40 ppm of the time since the reference.
  const double expected =
      250'000.0 + 40e-6 * static_cast<double>(system.now() - 1'700'000'000'000'000);
  EXPECT_NEAR(static_cast<double>(t - system.now()), expected, 50'000.0);
  EXPECT_NEAR(static_cast<double>(toTruth(a, t) - t), -expected, 1.0);
  setenv(kClockDriftVariable, "fast", 1);
  EXPECT_THROW(robotClockFromEnvironment(), config::Error);
  unsetenv(kClockOffsetVariable);
  unsetenv(kClockDriftVariable);
  unsetenv(kClockReferenceVariable);
  EXPECT_EQ(robotClockFromEnvironment().error().offset_us, 0);
}

}  // namespace robot_clock_test
}  // namespace fieldline::bus
