// Layer 2 of the localization (seed 4.12, MATRIX): corrects a pose guess so that the frame's line
// points, seen from that pose, fall onto the field's lines. Two methods on the same precomputed
// distance grid: the seed's force field with momentum (eq. 4.81-4.90), and a robust least-squares
// fit (Gauss-Newton / Levenberg-Marquardt with a Huber or Cauchy loss) whose covariance comes from
// the Hessian, so a robot that sees one long line is uncertain along it.
//
// Interface shared by the fusion filter (consumer) and the matcher (producer); the implementation
// lives in line_matcher.cpp.
#pragma once

#include <memory>
#include <span>

#include <Eigen/Core>

#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/line_points.hpp"

namespace fieldline::fusion {

enum class MatchMethod { kForceField, kRobustLeastSquares };

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
};

// A pose measurement from one frame's line points, at the frame's utime.
struct PoseCorrection {
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
  // skipped.
  PoseCorrection correct(std::span<const perception::LinePoint> points,
                         const geometry::Pose2& guess) const;
  // Mean matching cost (with the outlier cost) of the points seen from `pose`, m: used to test
  // hypotheses and to notice a robot that has been carried off.
  double cost(std::span<const perception::LinePoint> points, const geometry::Pose2& pose) const;

  const MatcherParams& params() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fieldline::fusion
