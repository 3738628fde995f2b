// The body's message conversions (common/msg): odometry_t and motion_command_t round trips,
// and an unknown command source read as unknown, not cast into the enum.
#include <gtest/gtest.h>

#include "common/msg/motion_command.hpp"
#include "common/msg/odometry.hpp"

namespace fieldline::msg {
namespace body_msg_test {

TEST(OdometryMsg, RoundTripKeepsEveryField) {
  perception::OdometryReading r;
  r.utime = 1'800'000'000'123'456;
  r.ticks = {-5, 2'000'000'000, 7};
  r.controller_utime = 98'765;
  r.movement = {0.01, -0.002, 0.03};
  r.vx = 0.5;
  r.vy = -0.1;
  r.omega = 1.5;
  r.status = perception::kOdometryResync | perception::kOdometryWatchdog |
             perception::kOdometryCurrents | perception::kOdometryGyro;
  r.wheel_current = {1.25f, -0.5f, 3.0f};
  r.gyro_dphi = -0.0123;
  odometry_t m{};
  toMessage(r, m);
  EXPECT_EQ(m.header.utime, r.utime);
  EXPECT_EQ(m.status, static_cast<std::int32_t>(odometry_t::STATUS_RESYNC) |
                          static_cast<std::int32_t>(odometry_t::STATUS_WATCHDOG) |
                          static_cast<std::int32_t>(odometry_t::STATUS_CURRENTS) |
                          static_cast<std::int32_t>(odometry_t::STATUS_GYRO));
  EXPECT_DOUBLE_EQ(m.gyro_dphi, -0.0123);
  EXPECT_FLOAT_EQ(m.wheel_current[1], -0.5f);
  const auto back = fromMessage(m);
  EXPECT_EQ(back.utime, r.utime);
  EXPECT_EQ(back.ticks, r.ticks);
  EXPECT_EQ(back.controller_utime, r.controller_utime);
  EXPECT_DOUBLE_EQ(back.movement.dx, 0.01);
  EXPECT_DOUBLE_EQ(back.movement.dy, -0.002);
  EXPECT_DOUBLE_EQ(back.movement.dphi, 0.03);
  EXPECT_DOUBLE_EQ(back.vx, 0.5);
  EXPECT_DOUBLE_EQ(back.vy, -0.1);
  EXPECT_DOUBLE_EQ(back.omega, 1.5);
  EXPECT_EQ(back.status, r.status);
  EXPECT_EQ(back.wheel_current, r.wheel_current);
  EXPECT_DOUBLE_EQ(back.gyro_dphi, -0.0123);
  EXPECT_EQ(m.wheel_count, 3);

  // Four wheels; without STATUS_CURRENTS the message carries zero currents, and none come back.
  r.ticks = {1, 2, 3, 4};
  r.wheel_current.clear();
  r.status = 0;
  toMessage(r, m);
  EXPECT_EQ(m.wheel_count, 4);
  EXPECT_EQ(m.ticks.size(), 4u);
  EXPECT_EQ(m.wheel_current, (std::vector<float>{0.0f, 0.0f, 0.0f, 0.0f}));
  const auto four = fromMessage(m);
  EXPECT_EQ(four.ticks, r.ticks);
  EXPECT_TRUE(four.wheel_current.empty());
  // A controller without ticks: wheel_count 0.
  r.ticks.clear();
  toMessage(r, m);
  EXPECT_EQ(m.wheel_count, 0);
  EXPECT_TRUE(m.ticks.empty());
  EXPECT_TRUE(fromMessage(m).ticks.empty());
}

TEST(MotionCommandMsg, RoundTripAndUnknownSource) {
  perception::MotionCommand c;
  c.utime = 1'800'000'000'000'000;
  c.vx = -0.25;
  c.vy = 0.75;
  c.omega = 0.1;
  c.deadline_utime = c.utime + 100'000;
  c.source = perception::CommandSource::kBehavior;
  motion_command_t m{};
  toMessage(c, m);
  EXPECT_EQ(m.source, motion_command_t::SOURCE_BEHAVIOR);
  const auto back = fromMessage(m);
  EXPECT_EQ(back.utime, c.utime);
  EXPECT_DOUBLE_EQ(back.vx, -0.25);
  EXPECT_DOUBLE_EQ(back.vy, 0.75);
  EXPECT_DOUBLE_EQ(back.omega, 0.1);
  EXPECT_EQ(back.deadline_utime, c.deadline_utime);
  EXPECT_EQ(back.source, perception::CommandSource::kBehavior);
  m.source = 42;
  EXPECT_EQ(fromMessage(m).source, perception::CommandSource::kUnknown);
}

}  // namespace body_msg_test
}  // namespace fieldline::msg
