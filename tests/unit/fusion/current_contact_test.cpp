// Contact from motor currents (services/fusion/current_contact.*): the current a wheel's own
// acceleration needs is no contact, a current at the friction limit in consecutive samples is,
// and bad currents are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "common/robot/robot_params.hpp"
#include "services/fusion/current_contact.hpp"

namespace fieldline::fusion {
namespace current_contact_test {

constexpr Utime kPeriod = 20'000;

struct Drive {
  robot::RobotParams robot = robot::loadRobotPreset("fu2004");
  double position[3] = {0.0, 0.0, 0.0};  // wheel travel [m]
  Utime t = 1'000'000;

  // The next sample after the wheels drove at `speed` with constant acceleration `accel` over
  // the period, with `current` on every wheel.
  OdometrySample next(double speed, double accel, double current) {
    OdometrySample s;
    t += kPeriod;
    s.utime = t;
    const double dt = static_cast<double>(kPeriod) * 1e-6;
    const double per_tick =
        2.0 * std::numbers::pi * robot.wheels[0].radius / robot.ticksPerWheelRevolution();
    for (std::size_t i = 0; i < 3; ++i) {
      position[i] += speed * dt + 0.5 * accel * dt * dt;
      s.ticks.push_back(static_cast<std::int32_t>(std::floor(position[i] / per_tick)));
      s.wheel_current.push_back(current);
    }
    s.has_currents = true;
    return s;
  }
  // Current that force F at the wheel takes.
  double amps(double force) const {
    return force * robot.wheels[0].radius / (robot.gear_ratio * robot.motor.torque_constant);
  }
};

CurrentContactParams params() {
  CurrentContactParams p;
  p.force_threshold_n = 8.0;
  p.samples = 2;
  return p;
}

TEST(CurrentContact, TheCurrentOfTheWheelsOwnAccelerationIsNoContact) {
  Drive d;
  CurrentContactDetector detector(d.robot, params());
  // 4 m/s^2 on every wheel: 10.7 N each, above the threshold, all explained by acceleration.
  const double accel = 4.0;
  const double force = d.robot.mass / 3.0 * accel;
  ASSERT_GT(force, params().force_threshold_n);
  double speed = 0.0;
  for (int k = 0; k < 30; ++k) {
    const auto r = detector.add(d.next(speed, accel, d.amps(force)));
    speed += accel * 0.02;
    EXPECT_FALSE(r.contact) << k;
    EXPECT_TRUE(r.rejection.empty());
    if (k >= 3) {
      EXPECT_LT(detector.lastResidualN(), 2.0) << k;
    }
  }
}

TEST(CurrentContact, AFrictionLimitCurrentInConsecutiveSamplesIsContact) {
  Drive d;
  CurrentContactDetector detector(d.robot, params());
  const double friction = 0.5 * d.robot.mass / 3.0 * 9.81;  // 13 N
  int contacts = 0;
  for (int k = 0; k < 10; ++k)
    contacts += detector.add(d.next(1.0, 0.0, 0.0)).contact ? 1 : 0;
  EXPECT_EQ(contacts, 0);
  // One slipping sample is carpet noise, not yet contact.
  EXPECT_FALSE(detector.add(d.next(1.0, 0.0, d.amps(friction))).contact);
  EXPECT_FALSE(detector.add(d.next(1.0, 0.0, 0.0)).contact);  // judges the slipping one
  EXPECT_GT(detector.lastResidualN(), 12.0);
  EXPECT_FALSE(detector.add(d.next(1.0, 0.0, 0.0)).contact);
  // Pushed: the wheel keeps its speed, the current sits at the limit.
  std::optional<Utime> first;
  const Utime push_start = d.t;
  for (int k = 0; k < 6; ++k) {
    const auto r = detector.add(d.next(1.0, 0.0, -d.amps(friction)));
    if (r.contact && !first) first = r.contact;
  }
  ASSERT_TRUE(first);
  // Reported for the period that showed it: the second slipping period starts 20 ms after the
  // push began; each judgement waits for the next sample.
  EXPECT_EQ(*first, push_start + kPeriod);
}

TEST(CurrentContact, CurrentsForAnotherWheelCountAreRefused) {
  Drive d;
  CurrentContactDetector detector(d.robot, params());
  OdometrySample four = d.next(0.5, 0.0, 0.0);
  four.wheel_current.push_back(0.0);
  four.ticks.push_back(0);
  EXPECT_EQ(detector.add(four).rejection, "current_wheel_count");
}

TEST(CurrentContact, BadCurrentsAreRefusedAndRestartTheHistory) {
  Drive d;
  CurrentContactDetector detector(d.robot, params());
  for (int k = 0; k < 5; ++k)
    detector.add(d.next(0.5, 0.0, 0.0));
  OdometrySample nan = d.next(0.5, 0.0, 0.0);
  nan.wheel_current[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(detector.add(nan).rejection, "current_not_finite");
  OdometrySample absurd = d.next(0.5, 0.0, 0.0);
  absurd.wheel_current[2] = -500.0;
  EXPECT_EQ(detector.add(absurd).rejection, "current_absurd");
  // After a refusal the detector needs four good samples before it judges again.
  const double huge = d.amps(100.0);
  for (int k = 0; k < 4; ++k)
    EXPECT_FALSE(detector.add(d.next(0.5, 0.0, huge)).contact) << k;
  EXPECT_TRUE(detector.add(d.next(0.5, 0.0, huge)).contact);
  // A sample without currents or with a resync restarts it too.
  OdometrySample none = d.next(0.5, 0.0, huge);
  none.has_currents = false;
  EXPECT_FALSE(detector.add(none).contact);
  EXPECT_FALSE(detector.add(d.next(0.5, 0.0, huge)).contact);
}

TEST(CurrentContact, OffAtZeroForceAndBadSettingsAreRefused) {
  Drive d;
  CurrentContactParams zero;
  zero.force_threshold_n = 0.0;
  CurrentContactDetector off(d.robot, zero);
  EXPECT_FALSE(off.enabled());
  for (int k = 0; k < 8; ++k)
    EXPECT_FALSE(off.add(d.next(0.5, 0.0, 30.0)).contact);
  CurrentContactParams bad = params();
  bad.samples = 0;
  EXPECT_THROW(CurrentContactDetector(d.robot, bad), std::invalid_argument);
  bad = params();
  bad.force_threshold_n = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(CurrentContactDetector(d.robot, bad), std::invalid_argument);
}

}  // namespace current_contact_test
}  // namespace fieldline::fusion
