// Layer 2 on synthetic line points (model lines seen from a known pose, with noise and clutter):
// both methods converge, the covariance follows what the points constrain, bad points are
// skipped, the global search finds the pose or its symmetric twin, config and params are checked.
#include "services/fusion/line_matcher.hpp"

#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>

#include "common/config/config.hpp"
#include "common/field/field_model.hpp"

namespace fieldline::fusion {
namespace {

using geometry::Pose2;
using geometry::Vec2;
using perception::LinePoint;

constexpr double kDeg = std::numbers::pi / 180.0;

LinePoint robotPoint(const Pose2& pose, const Vec2& field_point) {
  const Vec2 r = geometry::pointFieldToRobot(pose, field_point);
  LinePoint q;
  q.x = static_cast<float>(r.x());
  q.y = static_cast<float>(r.y());
  return q;
}

// Model line points within `range` of the robot, 1 cm noise, plus `clutter` random points.
std::vector<LinePoint> seenFrom(const field::FieldModel& field, const Pose2& pose, double range,
                                int clutter = 0, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_real_distribution<double> anywhere(-range, range);
  std::vector<LinePoint> points;
  for (const Vec2& p : field.sampleLines(0.05)) {
    if ((p - pose.position()).norm() > range) continue;
    points.push_back(robotPoint(pose, p + Vec2(noise(rng), noise(rng))));
  }
  for (int k = 0; k < clutter; ++k) {
    LinePoint q;
    q.x = static_cast<float>(anywhere(rng));
    q.y = static_cast<float>(anywhere(rng));
    points.push_back(q);
  }
  return points;
}

MatcherParams withMethod(MatchMethod method) {
  MatcherParams p;
  p.method = method;
  return p;
}

class LineMatcherTest : public ::testing::TestWithParam<MatchMethod> {
 protected:
  static void SetUpTestSuite() {
    field_ = new field::FieldModel(field::loadFieldPreset("msl"));
    cache_ = new std::string((std::filesystem::temp_directory_path() /
                              ("fieldline_matcher_test_" + std::to_string(std::random_device{}())))
                                 .string());
  }
  static void TearDownTestSuite() {
    std::error_code ignored;
    std::filesystem::remove_all(*cache_, ignored);
    delete field_;
    delete cache_;
  }
  LineMatcher matcher() const { return LineMatcher(*field_, withMethod(GetParam()), *cache_); }

  static field::FieldModel* field_;
  static std::string* cache_;
};
field::FieldModel* LineMatcherTest::field_ = nullptr;
std::string* LineMatcherTest::cache_ = nullptr;

TEST_P(LineMatcherTest, ConvergesFrom30cmAnd10DegreesOff) {
  const LineMatcher m = matcher();
  const std::vector<Pose2> truths = {
      {1.0, 0.5, 0.3}, {-6.0, -2.5, 2.0}, {7.5, 1.0, -1.0}, {-8.0, 4.0, 3.0}, {3.0, -5.0, -2.2}};
  // Clutter within the outlier distance pulls the seed's force field as much as a line point (it
  // averages forces); the robust fit shrugs it off. So the force field gets clean points here
  // and the clutter test below.
  const bool robust = GetParam() == MatchMethod::kRobustLeastSquares;
  int worst_iterations = 0;
  for (const Pose2& truth : truths) {
    const std::vector<LinePoint> points = seenFrom(*field_, truth, 4.0, robust ? 40 : 0);
    // Offsets in eight directions, heading off both ways.
    for (int k = 0; k < 8; ++k) {
      const double direction = k * std::numbers::pi / 4.0;
      const Pose2 guess{truth.x + 0.3 * std::cos(direction), truth.y + 0.3 * std::sin(direction),
                        truth.phi + (k % 2 ? 10.0 : -10.0) * kDeg};
      const PoseCorrection c = m.correct(points, guess, 1234);
      ASSERT_TRUE(c.valid) << truth.x << "," << truth.y << " k=" << k;
      EXPECT_EQ(c.utime, 1234);
      EXPECT_LT(std::hypot(c.pose.x - truth.x, c.pose.y - truth.y), 0.02)
          << truth.x << "," << truth.y << " k=" << k << " got " << c.pose.x << "," << c.pose.y;
      EXPECT_LT(std::abs(geometry::angleDiff(c.pose.phi, truth.phi)), 0.5 * kDeg)
          << truth.x << "," << truth.y << " k=" << k;
      EXPECT_LT(c.cost, 0.5 * m.cost(points, guess));
      worst_iterations = std::max(worst_iterations, c.iterations);
    }
  }
  std::printf("worst iterations %d\n", worst_iterations);
}

TEST_P(LineMatcherTest, ClutterBiasesTheForceFieldMoreThanTheRobustFit) {
  const LineMatcher m = matcher();
  const Pose2 truth{-6.0, -2.5, 2.0};
  const std::vector<LinePoint> points = seenFrom(*field_, truth, 4.0, 40);
  const PoseCorrection c = m.correct(points, {truth.x + 0.2, truth.y - 0.2, truth.phi + 0.1}, 0);
  ASSERT_TRUE(c.valid);
  const double error = std::hypot(c.pose.x - truth.x, c.pose.y - truth.y);
  EXPECT_LT(error, GetParam() == MatchMethod::kRobustLeastSquares ? 0.01 : 0.05);
  std::printf("error with clutter %.4f m\n", error);
}

TEST_P(LineMatcherTest, OneLineGivesACovarianceLongAlongIt) {
  const LineMatcher m = matcher();
  // Standing in the border beside the touch line (y = +W/2), seeing 4 m of it and nothing else.
  const double touch = field_->width() / 2.0;
  const Pose2 truth{-3.0, touch + 0.8, 0.4};
  std::vector<LinePoint> points;
  for (double x = -5.0; x <= -1.0; x += 0.02)
    points.push_back(robotPoint(truth, Vec2(x, touch)));
  const PoseCorrection c = m.correct(points, {truth.x + 0.1, truth.y - 0.1, truth.phi}, 0);
  ASSERT_TRUE(c.valid);
  // Across the line it is sure, along it the frame says almost nothing.
  EXPECT_NEAR(c.pose.y, truth.y, 0.01);
  const double sigma_along = std::sqrt(c.covariance(0, 0));
  const double sigma_across = std::sqrt(c.covariance(1, 1));
  EXPECT_GT(sigma_along, 1.0);
  EXPECT_LT(sigma_across, 0.02);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(c.covariance.topLeftCorner<2, 2>());
  const Vec2 major = eigen.eigenvectors().col(1);
  EXPECT_GT(std::abs(major.x()), 0.999) << major.transpose();  // the line runs along x
  EXPECT_GT(eigen.eigenvalues()(1), 1e4 * eigen.eigenvalues()(0));
  EXPECT_TRUE(Eigen::LLT<Eigen::Matrix3d>(c.covariance).info() == Eigen::Success);

  // A corner view constrains both directions: small and round.
  const Pose2 corner{7.0, -3.0, 0.7};
  const PoseCorrection both =
      m.correct(seenFrom(*field_, corner, 4.0), {corner.x + 0.1, corner.y, corner.phi}, 0);
  ASSERT_TRUE(both.valid);
  EXPECT_LT(std::sqrt(both.covariance(0, 0)), 0.02);
  EXPECT_LT(std::sqrt(both.covariance(1, 1)), 0.02);
  EXPECT_LT(std::sqrt(both.covariance(2, 2)), 1.0 * kDeg);
}

TEST_P(LineMatcherTest, NonFiniteAndFarPointsAreSkipped) {
  const LineMatcher m = matcher();
  const Pose2 truth{2.0, 1.0, -0.5};
  const std::vector<LinePoint> clean = seenFrom(*field_, truth, 4.0);
  std::vector<LinePoint> dirty = clean;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (const auto& [x, y] : std::vector<std::pair<float, float>>{
           {nan, 0.0f}, {0.0f, nan}, {inf, 1.0f}, {-inf, -inf}, {1e30f, 0.0f}, {50.0f, 3.0f}}) {
    LinePoint q;
    q.x = x;
    q.y = y;
    dirty.insert(dirty.begin() + static_cast<long>(dirty.size() / 2), q);
  }
  const Pose2 guess{truth.x + 0.2, truth.y - 0.1, truth.phi + 5 * kDeg};
  const PoseCorrection a = m.correct(clean, guess, 0);
  const PoseCorrection b = m.correct(dirty, guess, 0);
  ASSERT_TRUE(b.valid);
  EXPECT_EQ(a.points_used, b.points_used);
  EXPECT_EQ(static_cast<std::size_t>(b.points_used), clean.size());
  EXPECT_DOUBLE_EQ(a.pose.x, b.pose.x);
  EXPECT_DOUBLE_EQ(a.pose.phi, b.pose.phi);
  EXPECT_TRUE(b.covariance.allFinite());
  EXPECT_DOUBLE_EQ(m.cost(clean, truth), m.cost(dirty, truth));

  // Only garbage, or a NaN guess: invalid, finite, no crash.
  EXPECT_FALSE(m.correct(std::vector<LinePoint>(10, LinePoint{0, 0, nan, nan}), guess, 0).valid);
  EXPECT_FALSE(m.correct({}, guess, 0).valid);
  const PoseCorrection bad_guess = m.correct(clean, {nan, 0.0, 0.0}, 0);
  EXPECT_FALSE(bad_guess.valid);
  EXPECT_TRUE(bad_guess.covariance.allFinite());
  EXPECT_DOUBLE_EQ(m.cost(clean, {nan, 0.0, 0.0}), m.params().outlier_distance_m);
}

TEST_P(LineMatcherTest, CostIsTheSeedsMatchingDistance) {
  const LineMatcher m = matcher();
  const Pose2 truth{-1.0, 2.0, 1.0};
  const std::vector<LinePoint> points = seenFrom(*field_, truth, 4.0);
  EXPECT_LT(m.cost(points, truth), 0.015);
  // Seen from far off the field every point is an outlier and costs the outlier distance.
  EXPECT_DOUBLE_EQ(m.cost(points, {40.0, 40.0, 0.0}), m.params().outlier_distance_m);
  // A wrong guess costs more, and never more than the outlier cost.
  const double off = m.cost(points, {truth.x + 0.3, truth.y, truth.phi + 0.2});
  EXPECT_GT(off, 0.05);
  EXPECT_LE(off, m.params().outlier_distance_m);
  // Far from the lines: not valid.
  const PoseCorrection lost = m.correct(points, {40.0, 40.0, 0.0}, 0);
  EXPECT_FALSE(lost.valid);
}

INSTANTIATE_TEST_SUITE_P(BothMethods, LineMatcherTest,
                         ::testing::Values(MatchMethod::kForceField,
                                           MatchMethod::kRobustLeastSquares),
                         [](const auto& info) {
                           return info.param == MatchMethod::kForceField ? "ForceField"
                                                                         : "LeastSquares";
                         });

TEST(LineMatcher, HuberLossConvergesToo) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  MatcherParams p;
  p.loss = RobustLoss::kHuber;
  const LineMatcher m(field, p);
  const Pose2 truth{1.0, -0.5, 2.5};
  const PoseCorrection c =
      m.correct(seenFrom(field, truth, 3.5, 30), {truth.x - 0.2, truth.y + 0.2, truth.phi}, 0);
  ASSERT_TRUE(c.valid);
  EXPECT_LT(std::hypot(c.pose.x - truth.x, c.pose.y - truth.y), 0.02);
}

TEST(LineMatcher, GlobalSearchFindsThePoseOrItsTwin) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const LineMatcher m(field, MatcherParams{});
  for (const Pose2& truth : {Pose2{4.0, 2.0, 0.5}, Pose2{-7.0, -3.5, -2.0}}) {
    const std::vector<Pose2> acceptable = {
        truth, Pose2{-truth.x, -truth.y, geometry::normalizeAngle(truth.phi + std::numbers::pi)}};
    const std::vector<PoseCorrection> found = m.globalSearch(seenFrom(field, truth, 5.0, 30), {});
    ASSERT_FALSE(found.empty());
    bool hit = false;
    for (const Pose2& a : acceptable) {
      hit |= std::hypot(found[0].pose.x - a.x, found[0].pose.y - a.y) < 0.05 &&
             std::abs(geometry::angleDiff(found[0].pose.phi, a.phi)) < 2 * kDeg;
    }
    EXPECT_TRUE(hit) << "best " << found[0].pose.x << "," << found[0].pose.y << ","
                     << found[0].pose.phi << " cost " << found[0].cost;
    for (std::size_t k = 1; k < found.size(); ++k)
      EXPECT_GE(found[k].cost, found[k - 1].cost);
  }
  EXPECT_TRUE(m.globalSearch({}, {}).empty());
}

TEST(LineMatcher, ParamsFromConfig) {
  const config::Node node = config::Node::loadString(
      "method: force_field\nloss: huber\noutlier_distance_m: 0.4\npoint_sigma_m: 0.03\n");
  const MatcherParams p = loadMatcherParams(node);
  EXPECT_EQ(p.method, MatchMethod::kForceField);
  EXPECT_EQ(p.loss, RobustLoss::kHuber);
  EXPECT_DOUBLE_EQ(p.outlier_distance_m, 0.4);
  EXPECT_DOUBLE_EQ(p.point_sigma_m, 0.03);
  EXPECT_DOUBLE_EQ(p.grid_cell_m, MatcherParams{}.grid_cell_m);
  EXPECT_THROW(loadMatcherParams(config::Node::loadString("method: magic\n")), config::Error);
  EXPECT_THROW(loadMatcherParams(config::Node::loadString("outlier_distnce_m: 0.4\n")),
               config::Error);
  EXPECT_THROW(loadMatcherParams(config::Node::loadString("grid_margin_m: 0.2\n")), config::Error);
}

TEST(LineMatcher, BadParamsThrow) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  auto with = [](auto change) {
    MatcherParams p;
    change(p);
    return p;
  };
  EXPECT_THROW(LineMatcher(field, with([](MatcherParams& p) { p.grid_cell_m = 0; })),
               std::invalid_argument);
  EXPECT_THROW(LineMatcher(field, with([](MatcherParams& p) { p.point_sigma_m = std::nan(""); })),
               std::invalid_argument);
  EXPECT_THROW(LineMatcher(field, with([](MatcherParams& p) { p.grid_margin_m = 0.1; })),
               std::invalid_argument);
  EXPECT_THROW(LineMatcher(field, with([](MatcherParams& p) { p.min_inliers = 0; })),
               std::invalid_argument);
}

TEST(LineMatcher, GridComesFromTheCacheTheSecondTime) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("fieldline_matcher_cache_" + std::to_string(std::random_device{}()));
  MatcherParams p;
  p.grid_cell_m = 0.05;
  EXPECT_EQ(LineMatcher(field, p, dir.string()).gridSource(), "built");
  EXPECT_EQ(LineMatcher(field, p, dir.string()).gridSource(), "loaded");
  EXPECT_EQ(LineMatcher(field, p).gridSource(), "built");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace fieldline::fusion
