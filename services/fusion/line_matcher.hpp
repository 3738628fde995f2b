// Layer 2 of the localization (seed 4.12, MATRIX): corrects a pose guess so that the frame's line
// points, seen from that pose, fall onto the field's lines. Two methods on the same precomputed
// distance grid: the seed's force field with momentum (eq. 4.81-4.90), and a robust least-squares
// fit (Gauss-Newton / Levenberg-Marquardt with a Huber or Cauchy loss). The covariance comes from
// the shape of the cost around the answer (issue 30): the Hessian of the fit with neighbouring
// points counted as one (their errors are correlated: a mirror slightly off moves them together),
// inflated when the residuals are larger than the point model, widened along any direction where
// the cost rises more slowly than the Hessian says, and stretched toward the best other local
// minimum (an alias along the lines) as far as that one fits. A robot that sees one long line is
// uncertain along it; a frame that fits two places is uncertain between them.
//
// Interface shared by the fusion filter (consumer) and the matcher (producer); the implementation
// lives in line_matcher.cpp.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/line_points.hpp"

namespace fieldline::fusion {

enum class MatchMethod { kForceField, kRobustLeastSquares };
// Loss of the least-squares fit on each point's distance to its line.
enum class RobustLoss { kHuber, kCauchy };

struct MatcherParams {
  MatchMethod method = MatchMethod::kRobustLeastSquares;
  // Distance grid resolution and margin beyond the lines, m.
  double grid_cell_m = 0.02;
  double grid_margin_m = 1.0;
  // Points further than this from every line are outliers and cost this much (seed: 50 cm).
  double outlier_distance_m = 0.5;
  // Points beyond this range from the robot are not used (the mirror's far field is coarse), m.
  double max_point_range_m = 6.0;
  // The point model: standard deviation of the distance to its line of one group of neighbouring
  // points (a cell of correlation_length_m, whose points count as one: their errors are
  // correlated), m. The covariance grows when the residuals are larger than this.
  double point_sigma_m = 0.05;
  // Cell size of the groups, m (robot frame); 0: every point independent.
  double correlation_length_m = 0.3;
  // Far points are worth less (a pixel covers more floor, and a mirror slightly off moves them
  // most): a point at range r weighs 1 / (1 + (r / range_weight_m)^2) in the fit and the
  // covariance, m; 0: every point alike.
  double range_weight_m = 0.0;
  // How well the camera is known (the errors no residual shows: every point moves the same way):
  // the relative error of the mirror's distance function, a tilt (distances longer by this,
  // relative, toward one side and shorter on the other, in any direction), and where the mirror
  // axis stands (m). The pose's response to each, through the fit, adds to the covariance.
  // 0: the simulator's exact camera (what ships); withCalibratedCamera() for a real mirror.
  double camera_scale_sigma = 0.0;
  double camera_tilt_sigma = 0.0;
  double camera_axis_sigma_m = 0.0;

  // --- added by the matcher (defaults are the tested ones) ---
  // Fewer inliers than this at the corrected pose, or a smaller share of the points used, or a
  // mean matching cost above max_valid_cost_m: the correction is not valid (the points do not
  // fit the field there).
  int min_inliers = 20;
  double min_inlier_fraction = 0.5;
  double max_valid_cost_m = 0.15;
  // The search for the runner-up (the best other local minimum near the answer): the fit is
  // started again this far from the answer along both axes of its position covariance and turned
  // both ways (0: no search), m and rad; a minimum within runner_up_distinct_* of the answer is the
  // answer itself. A runner-up that fits better becomes the answer.
  double runner_up_offset_m = 0.3;
  double runner_up_offset_rad = 0.15;
  double runner_up_distinct_m = 0.08;
  double runner_up_distinct_rad = 0.04;
  // Check of the cost's shape: along each axis of the covariance the cost is probed 1.5 and 3
  // standard deviations out both ways, and the axis widened where it rises less than the
  // Hessian's quadratic (false: the Hessian alone).
  bool shape_check = true;
  // What the distance grid resolves at best (bilinear cells), added to the covariance, m and rad.
  double sigma_floor_m = 0.003;
  double sigma_floor_rad = 0.002;
  // Iteration limit (both methods) and the step below which they stop, m and rad.
  int max_iterations = 60;
  double converged_step = 5e-4;
  // Least squares: loss and its scale (distance where it turns from quadratic), m.
  RobustLoss loss = RobustLoss::kCauchy;
  double loss_scale_m = 0.15;
  // Force field: the seed's step width gamma for the translation (eq. 4.88) and for the turn the
  // moment gives (eq. 4.89, divided by the cloud's moment of inertia to be unit-free), and the
  // force field's decay and cap (eq. 4.81-4.84 in SI: eta = 10 / m, f_max = 1.5 m).
  double force_step = 1.0;
  double moment_step = 1.0;
  // Heavy-ball inertia of the force-field iteration (0: the seed's plain steps): carries part of
  // the last step into the next, so a direction that few points constrain converges in tens of
  // iterations instead of hundreds.
  double force_inertia = 0.5;
  double force_decay_per_m = 10.0;
  double force_cap_m = 1.5;
  // The covariance's weak prior: what the frame says about a direction it cannot see (along the
  // only visible line) is at most this certain, m and rad. Keeps the covariance positive definite.
  double unobservable_sigma_m = 5.0;
  double unobservable_sigma_rad = 1.0;
};

// `p` for a real robot's camera whose mirror is calibrated to within 3 % from 1 to 5 m (the
// tools that measure layer 2 on frames with camera errors or on real points use it; a real
// robot's fusion config sets its own calibration's figures).
inline MatcherParams withCalibratedCamera(MatcherParams p) {
  p.camera_scale_sigma = 0.01;
  p.camera_tilt_sigma = 0.01;
  p.camera_axis_sigma_m = 0.015;
  return p;
}

// Reads a `matcher` section (keys as the fields above, method: force_field | least_squares, loss:
// huber | cauchy); absent keys keep their defaults. Throws config::Error with file:line.
// Declared in matcherSettings() (fusion_config.cpp).
MatcherParams loadMatcherParams(const config::Node& node);

// The coarse search over the whole field when no guess is good (layer 3's fallback).
struct GlobalSearchParams {
  // Lattice of positions over the carpet and of headings, m and rad.
  double position_step_m = 0.4;
  double heading_step_rad = 0.1745329251994330;  // 10 degrees
  // Points the lattice is scored with (an even subsample of the frame's points).
  int scoring_points = 60;
  // Best lattice poses refined with correct(), and distinct answers returned at most.
  int refined = 24;
  int max_results = 6;
  // Answers closer than this to a better one are the same answer, m and rad.
  double distinct_m = 0.5;
  double distinct_rad = 0.35;
};

// A pose measurement from one frame's line points, at the frame's utime.
struct PoseCorrection {
  // The frame's time as the caller gave it, µs since the epoch (added by the matcher).
  std::int64_t utime = 0;
  // False when too few points matched for a meaningful answer.
  bool valid = false;
  geometry::Pose2 pose;
  // Covariance of (x, y, phi), m^2 / m*rad / rad^2, positive definite when valid.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  // Mean matching cost per point at the corrected pose (seed's matching distance), m.
  double cost = 0.0;
  // Points used and points within the outlier distance at the corrected pose.
  int points_used = 0;
  int inliers = 0;
  int iterations = 0;
  // The best other local minimum near the answer (an alias: the points slid along the lines),
  // when the runner-up search found one: its pose, its mean matching cost (m) and how much worse
  // it fits in units of the point model (half the chi-square difference of the cell-weighted
  // cost; 0: as well as the answer). The covariance covers it by its likelihood.
  bool has_runner_up = false;
  geometry::Pose2 runner_up;
  double runner_up_cost = 0.0;
  double runner_up_delta = 0.0;
  // How the covariance came about: the inliers' residual rms (cell-weighted, m), the factor the
  // point variance was inflated by (>= 1), the independent groups of points (cells), the largest
  // widening of an axis by the cost's shape (in variance, >= 1).
  double residual_rms_m = 0.0;
  double residual_inflation = 1.0;
  double independent_points = 0.0;
  double shape_widening = 1.0;
  // Why the correction is not valid (empty when it is).
  std::string invalid_reason;
};

class LineMatcher {
 public:
  // Builds (or loads from `cache_dir`, keyed by the field's parameters and the grid settings;
  // empty: no cache) the distance grid. Throws std::invalid_argument for bad params.
  LineMatcher(const field::FieldModel& field, MatcherParams params,
              const std::string& cache_dir = {});
  ~LineMatcher();
  LineMatcher(LineMatcher&&) noexcept;
  LineMatcher& operator=(LineMatcher&&) noexcept;

  // Corrects `guess` (field frame) with the line points (robot frame). Non-finite points are
  // skipped. `utime` (the frame's time) is copied into the result.
  PoseCorrection correct(std::span<const perception::LinePoint> points,
                         const geometry::Pose2& guess, std::int64_t utime = 0) const;
  // Mean matching cost (with the outlier cost) of the points seen from `pose`, m: used to test
  // hypotheses and to notice a robot that has been carried off.
  double cost(std::span<const perception::LinePoint> points, const geometry::Pose2& pose) const;

  const MatcherParams& params() const;

  // Poses over the whole field that fit the points, best (lowest cost) first, each refined with
  // correct() and distinct from the better ones. The field's symmetric twin of every answer fits
  // as well: both are returned, the caller resolves them. Empty when nothing fits (fewer than
  // min_inliers points match anywhere).
  // With `best_rejected`, the lowest-cost refined pose that was not valid is written there (its
  // invalid_reason says why; points_used 0 when there was none): what a tool says when nothing
  // fits.
  std::vector<PoseCorrection> globalSearch(std::span<const perception::LinePoint> points,
                                           const GlobalSearchParams& search = {},
                                           std::int64_t utime = 0,
                                           PoseCorrection* best_rejected = nullptr) const;

  // Whether the grid came from the cache ("loaded"), was built ("built") or replaced a bad cache
  // file ("rebuilt: <reason>"); for the status line.
  const std::string& gridSource() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fieldline::fusion
