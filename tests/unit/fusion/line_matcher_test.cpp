// Layer 2 on synthetic line points (model lines seen from a known pose, with noise and clutter):
// both methods converge, the covariance follows what the points constrain, bad points are
// skipped, the global search finds the pose or its symmetric twin, config and params are checked.
#include "services/fusion/line_matcher.hpp"

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "common/config/config.hpp"
#include "common/field/field_model.hpp"

namespace fieldline::fusion {
namespace line_matcher_test {

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

// The synthetic points come from an exact camera: no calibration uncertainty in the covariance.
MatcherParams withMethod(MatchMethod method) {
  MatcherParams p;
  p.method = method;
  p.camera_scale_sigma = 0.0;
  p.camera_tilt_sigma = 0.0;
  p.camera_axis_sigma_m = 0.0;
  return p;
}

class LineMatcherTest : public ::testing::TestWithParam<MatchMethod> {
 protected:
  static void SetUpTestSuite() {
    field_ = new field::FieldModel(field::loadFieldPreset("msl"));
    // Shared by the test processes (ctest runs each case in its own): the file name is keyed and
    // writes are atomic, so the grid is built once.
    cache_ = new std::string(
        (std::filesystem::temp_directory_path() / "fieldline_test_grid_cache").string());
  }
  static void TearDownTestSuite() {
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
  EXPECT_LT(sigma_across, 0.03);
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

TEST(LineMatcherHonesty, RepeatingThePointsDoesNotShrinkTheCovariance) {
  // Neighbouring points count as one group: the same frame sent again and again, 10^6 points in
  // all, says what it says once (a dense line sampling, or a tool fed 10^6 points, is no more
  // certain; it used to claim 0.2 mm).
  const field::FieldModel field = field::loadFieldPreset("msl");
  const LineMatcher m(field, MatcherParams{});
  const Pose2 truth{2.0, 1.0, -0.5};
  const std::vector<LinePoint> once = seenFrom(field, truth, 4.0);
  std::vector<LinePoint> many;
  while (many.size() < 1000000)
    many.insert(many.end(), once.begin(), once.end());
  const Pose2 guess{truth.x + 0.1, truth.y - 0.1, truth.phi + 0.05};
  const PoseCorrection a = m.correct(once, guess, 0);
  const PoseCorrection b = m.correct(many, guess, 0);
  ASSERT_TRUE(a.valid);
  ASSERT_TRUE(b.valid);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(b.covariance(k, k), a.covariance(k, k), 0.1 * a.covariance(k, k)) << k;
  EXPECT_NEAR(b.independent_points, a.independent_points, 1e-6);
  // Centimetres, not the tenth of a millimetre 10^5 independent points would claim.
  EXPECT_GT(std::sqrt(b.covariance(0, 0)), 0.005);
  std::printf("sigma x %.4f m once, %.4f m with %zu points\n", std::sqrt(a.covariance(0, 0)),
              std::sqrt(b.covariance(0, 0)), many.size());
}

TEST(LineMatcherHonesty, RandomPointsAreNotValidAnywhere) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const LineMatcher m(field, MatcherParams{});
  std::mt19937 rng(300);
  std::uniform_real_distribution<double> within(-6.0, 6.0);
  std::vector<LinePoint> random;
  while (random.size() < 300) {
    LinePoint q;
    q.x = static_cast<float>(within(rng));
    q.y = static_cast<float>(within(rng));
    if (std::hypot(q.x, q.y) <= 6.0) random.push_back(q);
  }
  EXPECT_TRUE(m.globalSearch(random).empty());
  for (const Pose2& guess : {Pose2{0.0, 0.0, 0.0}, Pose2{5.0, 3.0, 1.0}, Pose2{-8.0, -4.0, 2.0}}) {
    const PoseCorrection c = m.correct(random, guess, 0);
    EXPECT_FALSE(c.valid) << guess.x << "," << guess.y << " cost " << c.cost;
    EXPECT_FALSE(c.invalid_reason.empty());
  }
}

TEST(LineMatcherHonesty, ResidualsLargerThanThePointModelWidenTheCovariance) {
  // The same view, its points moved by errors shared by neighbours (8 cm, changing every half
  // metre along the view: a mirror that is off by a varying amount): larger residuals, a
  // wider covariance, and the true pose still within it.
  const field::FieldModel field = field::loadFieldPreset("msl");
  MatcherParams p = withMethod(MatchMethod::kRobustLeastSquares);
  p.point_sigma_m = 0.02;
  const LineMatcher m(field, p);
  const Pose2 truth{-6.0, -2.5, 2.0};
  const std::vector<LinePoint> clean = seenFrom(field, truth, 4.0);
  std::vector<LinePoint> bent = clean;
  std::mt19937 rng(9);
  std::normal_distribution<double> error(0.0, 0.08);
  std::map<std::pair<int, int>, Vec2> shared;
  for (LinePoint& q : bent) {
    const auto cell = std::make_pair(static_cast<int>(std::floor(q.x / 0.5)),
                                     static_cast<int>(std::floor(q.y / 0.5)));
    if (!shared.count(cell)) shared[cell] = Vec2(error(rng), error(rng));
    q.x += static_cast<float>(shared[cell].x());
    q.y += static_cast<float>(shared[cell].y());
  }
  const Pose2 guess{truth.x + 0.1, truth.y + 0.1, truth.phi};
  const PoseCorrection a = m.correct(clean, guess, 0);
  const PoseCorrection b = m.correct(bent, guess, 0);
  ASSERT_TRUE(a.valid);
  ASSERT_TRUE(b.valid) << b.invalid_reason;
  EXPECT_GT(b.residual_rms_m, 2.0 * a.residual_rms_m);
  EXPECT_GT(b.residual_inflation, 2.0);
  EXPECT_GT(b.covariance.trace(), 4.0 * a.covariance.trace());
  const Eigen::Vector3d e(b.pose.x - truth.x, b.pose.y - truth.y,
                          geometry::angleDiff(b.pose.phi, truth.phi));
  EXPECT_LT(e.dot(b.covariance.inverse() * e), 11.34);  // chi-square(3), 99 %
}

TEST(LineMatcherHonesty, AFrameThatFitsTwoPlacesNamesTheRunnerUpAndCoversIt) {
  // A lab field with only its rectangle and halfway line. Seen from `a` (0.5 m behind the
  // halfway line, 0.6 m from a touch line, facing +x) the points of both lines within 1.5 m; and
  // the same points again 0.6 m further forward: seen from `b`, 0.6 m behind `a`, the copies fall
  // on the lines, the originals 0.6 m off. Both places fit half of the frame exactly alike: the
  // answer, whichever it is, names the other as its runner-up and covers it. (The search
  // restarts 0.5 m out here: the default 0.3 m finds aliases up to about that far.)
  const field::FieldModel lab = field::loadFieldModel(config::Node::loadString(
      "name: lab\ndimensions_measured_to: line_centres\nlength: 8.0\nwidth: 3.0\n"
      "line_width: 0.05\nborder_width: 0.5\ngoals:\n  width: 1.0\n  depth: 0.3\n"
      "  height: 0.5\n  own_colour: white\n  opponent_colour: white\n",
      "lab.yaml"));
  MatcherParams p = withMethod(MatchMethod::kRobustLeastSquares);
  p.runner_up_offset_m = 0.5;
  // Half the frame fits either place: half the points are outliers.
  p.min_inlier_fraction = 0.3;
  p.max_valid_cost_m = 0.3;
  const LineMatcher m(lab, p);
  const Pose2 a{-0.5, 0.9, 0.0};
  const Pose2 b{-1.1, 0.9, 0.0};
  std::vector<LinePoint> points = seenFrom(lab, a, 1.5, 0, 1);
  const std::size_t count = points.size();
  for (std::size_t k = 0; k < count; ++k) {
    LinePoint q = points[k];
    q.x += 0.6f;
    points.push_back(q);
  }
  const PoseCorrection c = m.correct(points, {-0.6, 0.92, 0.02}, 0);
  ASSERT_TRUE(c.valid) << c.invalid_reason;
  ASSERT_TRUE(c.has_runner_up) << c.pose.x << "," << c.pose.y;
  const bool at_a = std::hypot(c.pose.x - a.x, c.pose.y - a.y) < 0.05;
  const bool at_b = std::hypot(c.pose.x - b.x, c.pose.y - b.y) < 0.05;
  ASSERT_TRUE(at_a || at_b) << c.pose.x << "," << c.pose.y;
  const Pose2& other = at_a ? b : a;
  EXPECT_LT(std::hypot(c.runner_up.x - other.x, c.runner_up.y - other.y), 0.05)
      << c.runner_up.x << "," << c.runner_up.y;
  EXPECT_LT(c.runner_up_delta, 2.0);
  // The other place is within the covariance, and the covariance is long between them.
  const Eigen::Vector3d e(other.x - c.pose.x, other.y - c.pose.y, 0.0);
  EXPECT_LT(e.dot(c.covariance.inverse() * e), 9.35);
  EXPECT_GT(std::sqrt(c.covariance(0, 0)), 3.0 * std::sqrt(c.covariance(1, 1)));
  std::printf("answer (%.3f, %.3f), runner-up (%.3f, %.3f), delta %.2f, sigma x %.3f y %.3f m\n",
              c.pose.x, c.pose.y, c.runner_up.x, c.runner_up.y, c.runner_up_delta,
              std::sqrt(c.covariance(0, 0)), std::sqrt(c.covariance(1, 1)));
}

TEST(LineMatcherHonesty, ValidNeedsABoundedCostAndMostPointsNearALine) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const LineMatcher m(field, MatcherParams{});
  const Pose2 truth{1.0, 0.5, 0.3};
  std::vector<LinePoint> points = seenFrom(field, truth, 4.0);
  const std::size_t lines = points.size();
  // As many points again in one clump about (3, 2) on the field, 1.6 m from every line: more
  // than half the frame fits no line.
  std::vector<LinePoint> half = points;
  for (std::size_t k = 0; k < lines + 10; ++k) {
    LinePoint q;
    q.x = 2.35f + static_cast<float>(k % 7) * 0.01f;
    q.y = 0.84f + static_cast<float>(k % 5) * 0.01f;
    half.push_back(q);
  }
  const PoseCorrection c = m.correct(half, truth, 0);
  EXPECT_FALSE(c.valid);
  EXPECT_NE(c.invalid_reason.find("too few of the points near a line"), std::string::npos)
      << c.invalid_reason;
  const PoseCorrection good = m.correct(points, truth, 0);
  EXPECT_TRUE(good.valid) << good.invalid_reason;
}

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

}  // namespace line_matcher_test
}  // namespace fieldline::fusion
