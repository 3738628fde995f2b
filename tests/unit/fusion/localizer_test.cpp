// Global localization and tracking with line points rendered from the field model: the robot
// finds itself from nothing (SEARCHING -> TRACKING) on the right half, follows a drive, notices
// being carried off and recovers, and reports ODOMETRY_ONLY when the lines stop. The matcher here
// is a slow pattern search on the exact field distance, standing in for layer 2.
#include "services/fusion/localizer.hpp"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tests/unit/fusion/test_world.hpp"

namespace fieldline::fusion {
namespace {

using test_support::TestWorld;
using test_support::world;

constexpr Utime kStart = 1'800'000'000'000'000;

// Drives the localizer: odometry at 50 Hz from `twist`, a line frame every 100 ms, 80 ms late.
struct Drive {
  Localizer localizer;
  robot::OmniKinematics kinematics;
  robot::TickCounts ticks{0, 0, 0};
  std::array<double, 3> remainder{};
  geometry::Pose2 truth;
  Utime t = kStart;
  std::mt19937 rng{11};
  int step = 0;
  bool lines = true;

  Drive(const geometry::Pose2& start, LocalizerParams params = {})
      : localizer(world().robot, params, world().functions()),
        kinematics(world().robot.wheels),
        truth(start) {
    localizer.addOdometry({t, ticks, false}, t);
  }

  void run(double seconds, const robot::Twist& twist) {
    const int steps = static_cast<int>(seconds / 0.02 + 0.5);
    for (int i = 0; i < steps; ++i) {
      t += 20'000;
      ++step;
      const Eigen::Vector3d wheel = kinematics.wheelAngularSpeeds(twist) * 0.02;
      for (std::size_t w = 0; w < 3; ++w) {
        const double exact = wheel[static_cast<int>(w)] / (2 * std::numbers::pi) *
                                 world().robot.ticksPerWheelRevolution() +
                             remainder[w];
        const double whole = std::round(exact);
        remainder[w] = exact - whole;
        ticks[w] += static_cast<std::int32_t>(whole);
      }
      truth = geometry::applyMovement(truth, robot::arcMovement(twist.vector() * 0.02));
      localizer.addOdometry({t, ticks, false}, t + 8'000);
      if (lines && step % 5 == 0) {
        // The frame was exposed 80 ms ago: its points are what the robot saw then. Keep the
        // truth of then.
        history.push_back({t, truth});
      }
      if (lines && step % 5 == 4 && !history.empty()) {
        const auto& [when, pose] = history.back();
        localizer.addLines(world().view(pose, rng), when, t + 8'000);
      }
    }
  }
  std::vector<std::pair<Utime, geometry::Pose2>> history;

  double error() const {
    const auto e = localizer.estimate(t + 8'000);
    return std::hypot(e.pose.x - truth.x, e.pose.y - truth.y);
  }
};

TEST(Localizer, FindsItselfFromNothingOnTheOwnHalf) {
  Drive d({-3.0, 1.2, 0.4});
  EXPECT_EQ(d.localizer.mode(), perception::LocalizationStatus::kUnknown);
  d.run(0.2, {});
  EXPECT_EQ(d.localizer.mode(), perception::LocalizationStatus::kSearching);
  d.run(1.0, {0.3, 0.0, 0.2});
  ASSERT_EQ(d.localizer.mode(), perception::LocalizationStatus::kTracking);
  EXPECT_LT(d.error(), 0.1);
  EXPECT_TRUE(d.localizer.ambiguous());  // only the own-half prior told the twins apart
  EXPECT_EQ(d.localizer.counters().commits, 1u);
}

TEST(Localizer, TracksADriveAndReportsOdometryOnlyWhenTheLinesStop) {
  Drive d({-2.0, -1.0, 0.0});
  d.run(1.0, {});
  ASSERT_EQ(d.localizer.mode(), perception::LocalizationStatus::kTracking);
  d.run(3.0, {0.8, 0.2, 0.5});
  EXPECT_LT(d.error(), 0.08);
  EXPECT_GT(d.localizer.counters().corrections, 20u);
  EXPECT_EQ(d.localizer.estimate(d.t + 8'000).status, perception::LocalizationStatus::kTracking);
  d.lines = false;
  d.run(1.5, {0.5, 0.0, 0.0});
  EXPECT_EQ(d.localizer.estimate(d.t + 8'000).status,
            perception::LocalizationStatus::kOdometryOnly);
  EXPECT_LT(d.error(), 0.3);
}

TEST(Localizer, NoticesBeingCarriedOffAndRecovers) {
  Drive d({-4.0, 2.0, 0.5});
  d.run(1.0, {0.2, 0.0, 0.0});
  ASSERT_EQ(d.localizer.mode(), perception::LocalizationStatus::kTracking);
  // Lifted and put down 2.5 m away, turned: the wheels do not see it.
  d.truth = {-2.0, -1.0, -0.8};
  d.history.clear();
  d.run(0.5, {0.2, 0.0, 0.0});
  EXPECT_GE(d.localizer.counters().lost, 1u);
  d.run(1.5, {0.2, 0.0, 0.1});
  ASSERT_EQ(d.localizer.mode(), perception::LocalizationStatus::kTracking);
  EXPECT_LT(d.error(), 0.1);
  EXPECT_FALSE(d.localizer.ambiguous());  // continuity chose the half
}

TEST(Localizer, FusesConsistentFeaturesAndRefusesBadOnes) {
  Drive d({-3.0, 0.5, 0.0});
  d.run(1.0, {});
  ASSERT_EQ(d.localizer.mode(), perception::LocalizationStatus::kTracking);
  perception::FieldFeatures f;
  f.features.push_back({perception::FeatureKind::kCentreCircle, {3.0, -0.5, 0.0}, 0.9});
  f.hypotheses.push_back({0, {d.truth.x + 0.03, d.truth.y, d.truth.phi}, 0.05, 0.03});
  d.localizer.addFeatures(f, d.t - 50'000, d.t + 8'000);
  EXPECT_EQ(d.localizer.counters().feature_updates, 1u);
  f.hypotheses[0].pose.x = std::nan("");
  d.localizer.addFeatures(f, d.t - 30'000, d.t + 8'000);
  EXPECT_EQ(d.localizer.counters().rejected.at("features_not_finite"), 1u);
  EXPECT_EQ(d.localizer.counters().feature_updates, 1u);
}

}  // namespace
}  // namespace fieldline::fusion
