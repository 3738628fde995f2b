// Constructed inputs shared by the tests of the odometry layer (odometry_layer_test.cpp), the
// EKF steps (ekf_test.cpp) and the delay-aware filter (history_test.cpp): wheel ticks of a
// robot driving a known twist, late line and feature measurements, a start state.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "common/robot/robot_params.hpp"
#include "services/fusion/history.hpp"
#include "services/fusion/localizer.hpp"
#include "services/fusion/odometry_layer.hpp"
#include "tests/unit/fusion/bare_params.hpp"

namespace fieldline::fusion::filter_inputs {

inline constexpr Utime kStart = 1'800'000'000'000'000;

inline robot::RobotParams params() {
  return robot::loadRobotPreset("fu2004");
}

// Ticks for a body twist held over dt, rounded like a real counter.
inline robot::TickCounts advanceTicks(const robot::TickCounts& ticks,
                                      const robot::OmniKinematics& kin, const robot::RobotParams& p,
                                      const robot::Twist& twist, double dt,
                                      std::array<double, 4>& remainder) {
  const robot::WheelVector wheel = kin.wheelAngularSpeeds(twist) * dt;
  robot::TickCounts out = ticks;
  for (std::size_t i = 0; i < ticks.size(); ++i) {
    const double exact =
        wheel[static_cast<int>(i)] / (2.0 * std::numbers::pi) * p.ticksPerWheelRevolution() +
        remainder[i];
    const double whole = std::round(exact);
    remainder[i] = exact - whole;
    out[i] =
        static_cast<std::int32_t>(static_cast<std::uint32_t>(ticks[i]) +
                                  static_cast<std::uint32_t>(static_cast<std::int64_t>(whole)));
  }
  return out;
}

struct Input {
  Utime arrival = 0;
  bool odometry = false;
  OdometryStep step;
  MeasurementSource source = MeasurementSource::kLines;
  PoseMeasurement z;
};

// A robot turning and accelerating for 3 s: odometry at 50 Hz (8 ms late), line measurements at
// 10 Hz and feature measurements at 5 Hz, each late by a random 0..150 ms. With `gyro` the
// odometry carries a gyro rotation with a bias of 0.004 rad/s.
inline std::vector<Input> makeInputs(std::mt19937& rng, bool gyro = false) {
  const auto p = params();
  OdometryLayer layer(p, test::bareOdometry());
  std::array<double, 4> rem{};
  robot::TickCounts ticks{0, 0, 0};
  layer.update({kStart, ticks, false});
  std::vector<Input> inputs;
  std::uniform_int_distribution<Utime> delay(0, 150'000);
  std::normal_distribution<double> noise(0.0, 0.03);
  geometry::Pose2 truth{-1.0, 0.5, 0.2};
  for (int k = 1; k <= 150; ++k) {
    const double t = k * 0.02;
    const robot::Twist twist{0.8 + 0.3 * std::sin(t), 0.2 * std::cos(2 * t), 0.6 * std::sin(t)};
    ticks = advanceTicks(ticks, layer.kinematics(), p, twist, 0.02, rem);
    const Utime utime = kStart + k * 20'000;
    OdometrySample sample{utime, ticks, false};
    sample.has_gyro = gyro;
    sample.gyro_dphi = (twist.omega + 0.004) * 0.02;
    const auto r = layer.update(sample);
    EXPECT_EQ(r.step->gyro, gyro);
    truth = geometry::applyMovement(truth, robot::arcMovement(twist.vector() * 0.02));
    Input in;
    in.arrival = utime + 8'000;
    in.odometry = true;
    in.step = *r.step;
    inputs.push_back(in);
    if (k % 5 == 2 || k % 10 == 7) {
      Input m;
      m.source = (k % 5 == 2) ? MeasurementSource::kLines : MeasurementSource::kFeatures;
      // Between odometry samples, as camera exposures are.
      m.z.utime = utime - 7'000;
      m.z.pose = {truth.x + noise(rng), truth.y + noise(rng), truth.phi + noise(rng)};
      m.z.covariance = Eigen::Vector3d(0.03 * 0.03, 0.05 * 0.05, 0.03 * 0.03).asDiagonal();
      m.z.covariance(0, 1) = m.z.covariance(1, 0) = 0.0005;
      m.arrival = m.z.utime + delay(rng);
      inputs.push_back(m);
    }
  }
  return inputs;
}

inline EkfState startState() {
  EkfState s;
  s.utime = kStart;
  s.x << -1.0, 0.5, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  s.p = (StateVector() << 0.01, 0.01, 0.01, 0.1, 0.1, 0.1, 1e-6, 0.0, 0.0).finished().asDiagonal();
  return s;
}

inline void feed(DelayedFilter& f, const Input& in, Utime now) {
  if (in.odometry) {
    EXPECT_EQ(f.addOdometry(in.step, now), Rejection::kNone);
  } else {
    f.addPose(in.source, in.z, now);
  }
}

inline Utime timeOf(const Input& in) {
  return in.odometry ? in.step.t_end : in.z.utime;
}

}  // namespace fieldline::fusion::filter_inputs
