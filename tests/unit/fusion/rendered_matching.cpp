// Layer 2 on realistic line points: frames rendered by the simulated camera (msl field, omni_sim
// camera) at known poses and run through the region tracker, then matched from guesses 30 cm and
// 10 degrees off with both methods. (Not named *_test.cpp: the folder's glob would put it into
// fusion_test, which does not link the renderer.)
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>

#include "services/fusion/line_matcher.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::fusion {
namespace {

using geometry::Pose2;
using perception::LinePoint;

constexpr double kDeg = std::numbers::pi / 180.0;

class RenderedMatching : public ::testing::TestWithParam<MatchMethod> {
 protected:
  static void SetUpTestSuite() {
    sim_ = new region_tracking::SimCamera(region_tracking::SimCamera::load("omni_sim", "msl"));
  }
  static void TearDownTestSuite() {
    delete sim_;
    sim_ = nullptr;
  }

  // The line points the tracker finds at `pose` after three frames (robot frame).
  static std::vector<LinePoint> linePointsAt(const Pose2& pose) {
    region_tracking::FrameProcessor processor(sim_->mirror, sim_->table,
                                              region_tracking::defaultVisionParams());
    camera::SimScene scene;
    scene.robot = pose;
    return sim_->track(processor, scene).lines.points;
  }

  LineMatcher matcher(double max_range = MatcherParams{}.max_point_range_m) const {
    MatcherParams p;
    p.method = GetParam();
    p.max_point_range_m = max_range;
    // Shared between the test processes: the file name is keyed, writes are atomic.
    const std::string cache =
        (std::filesystem::temp_directory_path() / "fieldline_test_grid_cache").string();
    return LineMatcher(sim_->field, p, cache);
  }

  static region_tracking::SimCamera* sim_;
};
region_tracking::SimCamera* RenderedMatching::sim_ = nullptr;

TEST_P(RenderedMatching, ConvergesFrom30cmAnd10DegreesOff) {
  const LineMatcher m = matcher();
  const std::vector<Pose2> truths = {
      {1.0, 0.5, 0.3}, {-2.0, -1.5, 2.0}, {7.5, 0.5, -1.0}, {-6.5, 0.5, 3.0}, {-3.0, 5.0, 0.8}};
  double worst_position = 0.0, worst_heading = 0.0;
  for (const Pose2& truth : truths) {
    const std::vector<LinePoint> points = linePointsAt(truth);
    ASSERT_GE(points.size(), 100u) << truth.x << "," << truth.y;
    for (int k = 0; k < 8; ++k) {
      const double direction = k * std::numbers::pi / 4.0 + 0.3;
      const Pose2 guess{truth.x + 0.3 * std::cos(direction), truth.y + 0.3 * std::sin(direction),
                        truth.phi + (k % 2 ? 10.0 : -10.0) * kDeg};
      const PoseCorrection c = m.correct(points, guess, 77);
      ASSERT_TRUE(c.valid) << truth.x << "," << truth.y << " k=" << k;
      EXPECT_EQ(c.utime, 77);
      const double position = std::hypot(c.pose.x - truth.x, c.pose.y - truth.y);
      const double heading = std::abs(geometry::angleDiff(c.pose.phi, truth.phi));
      EXPECT_LT(position, 0.04) << truth.x << "," << truth.y << " k=" << k << " got " << c.pose.x
                                << "," << c.pose.y << "," << c.pose.phi;
      EXPECT_LT(heading, 1.0 * kDeg) << truth.x << "," << truth.y << " k=" << k;
      // The answer's covariance admits the actual error (3 sigma, plus the grid's cell).
      const double sigma = std::sqrt(c.covariance(0, 0) + c.covariance(1, 1));
      EXPECT_LT(position, 3.0 * sigma + 0.02) << truth.x << "," << truth.y << " k=" << k;
      worst_position = std::max(worst_position, position);
      worst_heading = std::max(worst_heading, heading);
    }
    std::printf("pose (%.1f, %.1f, %.1f): %zu points\n", truth.x, truth.y, truth.phi,
                points.size());
  }
  std::printf("worst error %.4f m, %.3f deg\n", worst_position, worst_heading / kDeg);
}

TEST_P(RenderedMatching, SeeingOneLineGivesACovarianceLongAlongIt) {
  // In the border beside the touch line, far from the halfway line and the penalty area: within
  // 4 m the touch line (along x) is all the camera sees.
  const LineMatcher m = matcher(4.0);
  const double touch = sim_->field.width() / 2.0;
  const Pose2 truth{-4.5, touch + 0.7, 0.5};
  const std::vector<LinePoint> points = linePointsAt(truth);
  ASSERT_GE(points.size(), 30u);
  const PoseCorrection c = m.correct(points, {truth.x - 0.2, truth.y + 0.15, truth.phi + 0.1}, 0);
  ASSERT_TRUE(c.valid);
  EXPECT_NEAR(c.pose.y, truth.y, 0.03);
  EXPECT_NEAR(geometry::angleDiff(c.pose.phi, truth.phi), 0.0, 1.0 * kDeg);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(c.covariance.topLeftCorner<2, 2>());
  const geometry::Vec2 major = eigen.eigenvectors().col(1);
  EXPECT_GT(std::abs(major.x()), 0.99) << major.transpose();
  EXPECT_GT(std::sqrt(eigen.eigenvalues()(1)), 30.0 * std::sqrt(eigen.eigenvalues()(0)));
  std::printf("one line: %zu points, sigma along %.3f m, across %.4f m\n", points.size(),
              std::sqrt(eigen.eigenvalues()(1)), std::sqrt(eigen.eigenvalues()(0)));
}

TEST_P(RenderedMatching, NoBiasNearThePenaltyAreasCorner) {
  // Where the kidnap scenario puts robot 1 down (docs/log/2026-12-02-fusion.md, tenth round): the
  // visible lines (penalty area, goal line, touch line) all lie on one side. Until the renderer
  // interpolated its floor raster, each line's edges sat on the boundaries of footprint-sized cells
  // fixed on the field, and layer 2 from the true pose was off by (+1.1, -1.2) cm on average over
  // these nine poses 5 cm apart, the same way in every frame. Now the mean is under 1 mm; the
  // frames' own scatter (a few mm) is what the filter may average. The least-squares fit (the
  // default) only: the force field's forces, looked up at the nearest grid node and weighted toward
  // the nearer line, end (+0.4, +0.8) cm off here.
  if (GetParam() == MatchMethod::kForceField) GTEST_SKIP() << "least squares only";
  const LineMatcher m = matcher();
  double sum_x = 0.0, sum_y = 0.0;
  int n = 0;
  for (int k = 0; k < 9; ++k) {
    const Pose2 truth{-6.5 + 0.05 * k, 2.4, 2.4};
    const PoseCorrection c = m.correct(linePointsAt(truth), truth);
    ASSERT_TRUE(c.valid) << truth.x;
    sum_x += c.pose.x - truth.x;
    sum_y += c.pose.y - truth.y;
    ++n;
  }
  std::printf("mean error near the penalty area's corner (%.2f, %.2f) cm\n", 100 * sum_x / n,
              100 * sum_y / n);
  EXPECT_LT(std::abs(sum_x / n), 0.004);
  EXPECT_LT(std::abs(sum_y / n), 0.004);
}

INSTANTIATE_TEST_SUITE_P(BothMethods, RenderedMatching,
                         ::testing::Values(MatchMethod::kForceField,
                                           MatchMethod::kRobustLeastSquares),
                         [](const auto& info) {
                           return info.param == MatchMethod::kForceField ? "ForceField"
                                                                         : "LeastSquares";
                         });

TEST_P(RenderedMatching, GlobalSearchFindsThePoseOrItsTwinWithoutAGuess) {
  const LineMatcher m = matcher();
  const Pose2 truth{-7.0, 2.0, 0.6};
  const std::vector<PoseCorrection> found = m.globalSearch(linePointsAt(truth));
  ASSERT_FALSE(found.empty());
  const Pose2 twin{-truth.x, -truth.y, geometry::normalizeAngle(truth.phi + std::numbers::pi)};
  bool hit = false;
  for (const Pose2& a : {truth, twin}) {
    hit |= std::hypot(found[0].pose.x - a.x, found[0].pose.y - a.y) < 0.05 &&
           std::abs(geometry::angleDiff(found[0].pose.phi, a.phi)) < 2 * kDeg;
  }
  EXPECT_TRUE(hit) << found[0].pose.x << "," << found[0].pose.y << "," << found[0].pose.phi;
}

// Layer 2's answers bit for bit (a speed change must keep them): FNV-1a over every figure of
// correct() (pose, covariance, costs, counts, runner-up, diagnostics) at five rendered poses from
// guesses 3.5 cm / 1 degree and 30 cm / 10 degrees off in four directions, of cost() at each
// guess and of one global search. The digests were taken with the matcher of main cd74977
// (session 9, before its layer-2 loops were rewritten); re-pinned 2026-12-07 (session 11) when
// the simulated camera's sensor noise came from another generator of the same distribution (the
// rendered frames' noise, so the line points, changed; the matcher did not), and again in
// session 12 when that noise got the sigma the config asks (finding 1; the same reason).
class Fnv {
 public:
  void mix(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) {
      hash_ ^= (v >> (8 * i)) & 0xffu;
      hash_ *= 0x100000001b3ull;
    }
  }
  void mix(double v) { mix(std::bit_cast<std::uint64_t>(v)); }
  void mix(const Pose2& p) {
    mix(p.x);
    mix(p.y);
    mix(p.phi);
  }
  void mix(const PoseCorrection& c) {
    mix(static_cast<std::uint64_t>(c.utime));
    mix(static_cast<std::uint64_t>(c.valid));
    mix(c.pose);
    for (int k = 0; k < 9; ++k)
      mix(c.covariance(k / 3, k % 3));
    mix(c.cost);
    mix(static_cast<std::uint64_t>(c.points_used));
    mix(static_cast<std::uint64_t>(c.inliers));
    mix(static_cast<std::uint64_t>(c.iterations));
    mix(static_cast<std::uint64_t>(c.has_runner_up));
    mix(c.runner_up);
    mix(c.runner_up_cost);
    mix(c.runner_up_delta);
    mix(c.residual_rms_m);
    mix(c.residual_inflation);
    mix(c.independent_points);
    mix(c.shape_widening);
    for (const char ch : c.invalid_reason)
      mix(static_cast<std::uint64_t>(static_cast<unsigned char>(ch)));
  }
  std::uint64_t value() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ull;
};

TEST_P(RenderedMatching, CorrectionsKeepTheirBits) {
  const LineMatcher m = matcher();
  const std::vector<Pose2> truths = {
      {1.0, 0.5, 0.3}, {-2.0, -1.5, 2.0}, {7.5, 0.5, -1.0}, {-6.5, 0.5, 3.0}, {-3.0, 5.0, 0.8}};
  Fnv digest;
  int valid = 0;
  for (const Pose2& truth : truths) {
    const std::vector<LinePoint> points = linePointsAt(truth);
    for (int k = 0; k < 8; ++k) {
      const double direction = k * std::numbers::pi / 2.0 + 0.7;
      const double offset = k < 4 ? 0.035 : 0.30;
      const double turn = (k < 4 ? 1.0 : 10.0) * (k % 2 ? 1.0 : -1.0) * kDeg;
      const Pose2 guess{truth.x + offset * std::cos(direction),
                        truth.y + offset * std::sin(direction), truth.phi + turn};
      const PoseCorrection c = m.correct(points, guess, 1000 + k);
      valid += c.valid ? 1 : 0;
      digest.mix(c);
      digest.mix(m.cost(points, guess));
    }
  }
  for (const PoseCorrection& c : m.globalSearch(linePointsAt({-7.0, 2.0, 0.6})))
    digest.mix(c);
  EXPECT_EQ(valid, 40);
  const std::uint64_t expected =
      GetParam() == MatchMethod::kForceField ? 0xa3ef499f1e48467eull : 0x66e92e7bc1656df2ull;
  EXPECT_EQ(digest.value(), expected) << std::hex << "digest 0x" << digest.value();
}

}  // namespace
}  // namespace fieldline::fusion
