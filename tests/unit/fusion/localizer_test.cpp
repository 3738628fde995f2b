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

#include "common/field/field_model.hpp"
#include "common/robot/robot_params.hpp"

namespace fieldline::fusion {
namespace {

constexpr Utime kStart = 1'800'000'000'000'000;

struct TestWorld {
  field::FieldModel field = field::loadFieldPreset("msl");
  robot::RobotParams robot = robot::loadRobotPreset("fu2004");
  std::vector<geometry::Vec2> line_points;

  TestWorld() {
    for (const auto& s : field.segments()) {
      const int n = static_cast<int>(s.length() / 0.1);
      for (int i = 0; i <= n; ++i)
        line_points.push_back(s.a + (s.b - s.a) * (static_cast<double>(i) / std::max(n, 1)));
    }
    for (const auto& a : field.arcs()) {
      const int n = static_cast<int>(std::abs(a.sweep) * a.radius / 0.1);
      for (int i = 0; i <= n; ++i)
        line_points.push_back(a.pointAt(a.start_angle + a.sweep * i / std::max(n, 1)));
    }
  }

  // The field-line points within 4 m, in the robot frame, with 1 cm noise.
  std::vector<perception::LinePoint> view(const geometry::Pose2& pose, std::mt19937& rng) const {
    std::normal_distribution<double> noise(0.0, 0.01);
    std::vector<perception::LinePoint> out;
    for (const auto& p : line_points) {
      const geometry::Vec2 local = geometry::pointFieldToRobot(pose, p);
      if (local.norm() > 4.0 || local.norm() < 0.3) continue;
      perception::LinePoint lp;
      lp.x = static_cast<float>(local.x() + noise(rng));
      lp.y = static_cast<float>(local.y() + noise(rng));
      out.push_back(lp);
    }
    return out;
  }

  double cost(std::span<const perception::LinePoint> points, const geometry::Pose2& pose) const {
    if (points.empty()) return 0.5;
    double sum = 0.0;
    for (const auto& lp : points) {
      const geometry::Vec2 f = geometry::pointRobotToField(pose, {lp.x, lp.y});
      sum += std::min(field.distance(f), 0.5);
    }
    return sum / static_cast<double>(points.size());
  }

  PoseCorrection correct(std::span<const perception::LinePoint> points,
                         const geometry::Pose2& guess) const {
    PoseCorrection c;
    c.points_used = static_cast<int>(points.size());
    if (points.size() < 10) return c;
    // Pattern search: good enough for a test, far too slow for a robot.
    geometry::Pose2 best = guess;
    double best_cost = cost(points, best);
    for (double step = 0.2; step > 0.004; step *= 0.5) {
      bool improved = true;
      while (improved) {
        improved = false;
        const geometry::Pose2 moves[6] = {{step, 0, 0},  {-step, 0, 0},      {0, step, 0},
                                          {0, -step, 0}, {0, 0, step * 0.5}, {0, 0, -step * 0.5}};
        for (const auto& m : moves) {
          geometry::Pose2 p{best.x + m.x, best.y + m.y, geometry::normalizeAngle(best.phi + m.phi)};
          const double cp = cost(points, p);
          if (cp < best_cost - 1e-9) {
            best = p;
            best_cost = cp;
            improved = true;
          }
        }
      }
    }
    c.valid = true;
    c.pose = best;
    c.cost = best_cost;
    c.covariance = Eigen::Vector3d(0.03 * 0.03, 0.03 * 0.03, 0.02 * 0.02).asDiagonal();
    return c;
  }

  MatcherFunctions functions() const {
    return {[this](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
              return correct(p, g);
            },
            [this](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
              return cost(p, g);
            }};
  }
};

const TestWorld& world() {
  static const TestWorld w;
  return w;
}

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
