// Layer 2 of the localization (seed 4.12, MATRIX): corrects a pose guess so that the frame's line
// points, seen from that pose, fall onto the field's lines. Two methods on the same precomputed
// distance grid: the seed's force field with momentum (eq. 4.81-4.90), and a robust least-squares
// fit (Gauss-Newton / Levenberg-Marquardt with a Huber or Cauchy loss) whose covariance comes from
// the Hessian, so a robot that sees one long line is uncertain along it.
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
  // Standard deviation of one line point's distance to its line, m (scales the covariance).
  double point_sigma_m = 0.05;

  // --- added by the matcher (defaults are the tested ones) ---
  // Fewer inliers than this at the corrected pose: the correction is not valid.
  int min_inliers = 20;
  // Iteration limit (both methods) and the step below which they stop, m and rad.
  int max_iterations = 60;
  double converged_step = 1e-4;
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
  double force_inertia = 0.8;
  double force_decay_per_m = 10.0;
  double force_cap_m = 1.5;
  // The covariance's weak prior: what the frame says about a direction it cannot see (along the
  // only visible line) is at most this certain, m and rad. Keeps the covariance positive definite.
  double unobservable_sigma_m = 5.0;
  double unobservable_sigma_rad = 1.0;
};

// Reads a `matcher` section (keys as the fields above, method: force_field | least_squares, loss:
// huber | cauchy); absent keys keep their defaults. Throws config::Error with file:line.
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
  std::vector<PoseCorrection> globalSearch(std::span<const perception::LinePoint> points,
                                           const GlobalSearchParams& search = {},
                                           std::int64_t utime = 0) const;

  // Whether the grid came from the cache ("loaded"), was built ("built") or replaced a bad cache
  // file ("rebuilt: <reason>"); for the status line.
  const std::string& gridSource() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fieldline::fusion
