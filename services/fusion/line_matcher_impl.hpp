// LineMatcher's implementation (line_matcher.hpp), shared by its files: the robust fit
// (line_fit.cpp), the answer's analysis and covariance (line_fit_analysis.cpp), and the public
// functions with the global search (line_matcher.cpp).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "services/fusion/line_grid.hpp"
#include "services/fusion/line_matcher.hpp"

namespace fieldline::fusion {

// A usable line point in the robot frame, and its weight by range (MatcherParams::
// range_weight_m; 1 without).
// Throws std::invalid_argument naming the first setting out of its range (the constructor's
// check of its settings; matcher_params.cpp).
void validateMatcherParams(const MatcherParams& params);

struct RobotPoint {
  double x;
  double y;
  double w = 1.0;
};

// Finite points within range; the rest are skipped. With `range_weight` (m, > 0) a point at
// range r weighs 1 / (1 + (r / range_weight)^2).
void usablePoints(std::span<const perception::LinePoint> points, double max_range,
                  double range_weight, std::vector<RobotPoint>& out);

struct LineMatcher::Impl {
  MatcherParams params;
  LineGrid grid;
  std::string source;
  field::Vec2 carpet_half;
  // Every few nodes of the grid's distances (about 10 cm apart), clipped at the outlier
  // distance: small enough to stay in cache while the global search scores its lattice.
  std::vector<float> coarse;
  double coarse_cell = 0.0;
  int coarse_cols = 0;
  int coarse_rows = 0;

  void buildCoarse() {
    const int stride = std::max(1, static_cast<int>(std::lround(0.1 / grid.cellSize())));
    coarse_cell = stride * grid.cellSize();
    coarse_cols = (grid.columns() - 1) / stride + 1;
    coarse_rows = (grid.rows() - 1) / stride + 1;
    coarse.resize(static_cast<std::size_t>(coarse_cols) * coarse_rows);
    for (int j = 0; j < coarse_rows; ++j) {
      for (int i = 0; i < coarse_cols; ++i) {
        coarse[static_cast<std::size_t>(j) * coarse_cols + i] =
            std::min(grid.node(i * stride, j * stride).distance,
                     static_cast<float>(params.outlier_distance_m));
      }
    }
  }
  // Nearest coarse node's clipped distance; the outlier distance off the grid.
  double coarseDistance(double x, double y) const {
    const double u = (x - grid.originX()) / coarse_cell + 0.5;
    const double v = (y - grid.originY()) / coarse_cell + 0.5;
    if (!(u >= 0.0 && v >= 0.0 && u < coarse_cols && v < coarse_rows)) {
      return params.outlier_distance_m;
    }
    return coarse[static_cast<std::size_t>(static_cast<int>(v)) * coarse_cols +
                  static_cast<int>(u)];
  }

  // The loops over a frame's points ask for the grid's cache lines of the point this many ahead
  // of the one they read (LineGrid::prefetch): in the team most of linearize()'s perf samples
  // fall on the grid's reads. Four is a guess, not a measured optimum.
  static constexpr std::size_t kPrefetchAhead = 4;
  void prefetchAt(const RobotPoint& q, const geometry::Pose2& pose, double c, double s) const {
    grid.prefetch(pose.x + (c * q.x - s * q.y), pose.y + (s * q.x + c * q.y));
  }

  // Normal equations of the robust fit at one pose (iteratively reweighted: w(d) of the loss).
  struct Linearization {
    Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
    double robust_cost = 0.0;
    // The seed's matching distance summed (outliers at the outlier cost) and the inliers.
    double seed_sum = 0.0;
    int inliers = 0;
  };

  double rho(double d) const {
    const double c = params.loss_scale_m;
    if (params.loss == RobustLoss::kHuber) return d <= c ? 0.5 * d * d : c * (d - 0.5 * c);
    return 0.5 * c * c * std::log1p((d * d) / (c * c));
  }
  double weight(double d) const {
    const double c = params.loss_scale_m;
    if (params.loss == RobustLoss::kHuber) return d <= c ? 1.0 : c / d;
    return 1.0 / (1.0 + (d * d) / (c * c));
  }

  Linearization linearize(const std::vector<RobotPoint>& points, const geometry::Pose2& pose) const;

  // Levenberg-Marquardt on the robust cost; every trial pose is linearized once, which also
  // decides whether it is accepted.
  geometry::Pose2 leastSquares(const std::vector<RobotPoint>& points, geometry::Pose2 pose,
                               int& iterations, Linearization& current) const;

  // The seed's force field (eq. 4.85-4.89): the mean force translates the cloud, the mean moment
  // about its centre of gravity turns it, until the steps vanish (with heavy-ball inertia). Points
  // further than the outlier distance from every line are discarded.
  geometry::Pose2 forceField(const std::vector<RobotPoint>& points, geometry::Pose2 pose,
                             int& iterations) const;

  // The seed's matching distance (eq. 4.73/4.79): mean distance, outliers at the outlier cost.
  double seedCost(const std::vector<RobotPoint>& points, const geometry::Pose2& pose,
                  int* inliers) const;

  // The configured method from `start`; the linearization at its answer in `at`.
  geometry::Pose2 optimize(const std::vector<RobotPoint>& points, const geometry::Pose2& start,
                           int& iterations, Linearization& at) const {
    geometry::Pose2 pose;
    if (params.method == MatchMethod::kForceField) {
      pose = forceField(points, start, iterations);
      at = linearize(points, pose);
    } else {
      pose = leastSquares(points, start, iterations, at);
    }
    pose.phi = geometry::normalizeAngle(pose.phi);
    return pose;
  }

  // Each point's weight as one of the group of points in its cell (correlation_length_m square,
  // robot frame): 1 / (points in the cell). Neighbouring points share their error (a mirror
  // slightly off, a tilted camera, a blurred edge move them together), so a group says about as
  // much as one point, however densely the line was sampled.
  void cellWeights(const std::vector<RobotPoint>& points, std::vector<double>& weights) const;

  // The cell-weighted robust cost (outliers at the outlier cost).
  double weightedCost(const std::vector<RobotPoint>& points, const std::vector<double>& weights,
                      const geometry::Pose2& pose) const {
    const double c = std::cos(pose.phi), s = std::sin(pose.phi);
    const double outlier_rho = rho(params.outlier_distance_m);
    double sum = 0.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const RobotPoint& q = points[i];
      if (i + kPrefetchAhead < points.size()) prefetchAt(points[i + kPrefetchAhead], pose, c, s);
      double d;
      const bool on = grid.distance(pose.x + c * q.x - s * q.y, pose.y + s * q.x + c * q.y, d);
      sum += weights[i] * q.w * (on && d <= params.outlier_distance_m ? rho(d) : outlier_rho);
    }
    return sum;
  }

  // The cell-weighted normal equations at `pose` and the inliers' weighted residuals.
  struct WeightedFit {
    Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
    double weight_sum = 0.0;
    double weighted_squares = 0.0;
    // Sum of the inliers' cell weights: the independent groups that matched.
    double independent = 0.0;
    // J^T W (d distance / d camera parameter) for the distance function's scale and the two
    // components of a tilt (cos, sin of the bearing).
    Eigen::Vector3d scale = Eigen::Vector3d::Zero();
    Eigen::Vector3d tilt_cos = Eigen::Vector3d::Zero();
    Eigen::Vector3d tilt_sin = Eigen::Vector3d::Zero();
  };
  WeightedFit weightedFit(const std::vector<RobotPoint>& points, const std::vector<double>& weights,
                          const geometry::Pose2& pose) const;

  // The camera's calibration errors (MatcherParams::camera_*), through the fit: a parameter
  // error e moves the answer by -H^-1 J^T W (dd/de) e, whatever the residuals say.
  void addCameraErrors(const WeightedFit& fit, double scale, const Eigen::Matrix3d& prior,
                       Eigen::Matrix3d& covariance) const;

  // The covariance from the shape of the cost at `pose` (see the header); fills the diagnostics
  // of `out`, and `cost_at_pose` with weightedCost at `pose` when the shape check took it.
  Eigen::Matrix3d shapeCovariance(const std::vector<RobotPoint>& points,
                                  const std::vector<double>& weights, const geometry::Pose2& pose,
                                  PoseCorrection& out, std::optional<double>& cost_at_pose) const;

  // A local minimum of the robust cost.
  struct Minimum {
    geometry::Pose2 pose;
    Linearization at;
  };
  // The runner-up of the answer (`pose`, `at`): the fit restarted along the position's
  // uncertainty axes (runner_up_offset_m) and in heading (runner_up_offset_rad). A better
  // minimum becomes the answer (pose and at change, the old answer becomes a candidate); returns
  // the best other distinct minimum, if any.
  std::optional<Minimum> searchRunnerUp(const std::vector<RobotPoint>& points,
                                        geometry::Pose2& pose, Linearization& at) const;

  // Why the answer `out` (at `pose`, its covariance positive definite or not) is not valid; empty
  // when it is.
  std::string invalidReason(const PoseCorrection& out, const geometry::Pose2& pose,
                            bool positive) const;

  // The best `search.refined` poses of a lattice over the field (position_step_m apart, every
  // heading_step_rad), scored with an even subsample of `usable` (scoring_points of them) by the
  // seed's cost, outliers at the outlier distance; the worst of them first.
  std::vector<geometry::Pose2> bestLatticePoses(const std::vector<RobotPoint>& usable,
                                                const GlobalSearchParams& search) const;

  // The full answer from `guess`: the fit, the runner-up search, the covariance. With `analyse`
  // false only the fit and a Hessian covariance (the global search's lattice refinement).
  PoseCorrection correct(const std::vector<RobotPoint>& points, const geometry::Pose2& guess,
                         std::int64_t utime, bool analyse = true) const;
};

}  // namespace fieldline::fusion
