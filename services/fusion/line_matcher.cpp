#include "services/fusion/line_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <queue>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "services/fusion/line_grid.hpp"

namespace fieldline::fusion {
namespace {

// A usable line point in the robot frame, and its weight by range (MatcherParams::
// range_weight_m; 1 without).
struct RobotPoint {
  double x;
  double y;
  double w = 1.0;
};

void requirePositive(double value, const char* name) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw std::invalid_argument(std::string("MatcherParams: ") + name + " must be positive");
  }
}

void validate(const MatcherParams& p) {
  requirePositive(p.grid_cell_m, "grid_cell_m");
  requirePositive(p.outlier_distance_m, "outlier_distance_m");
  requirePositive(p.max_point_range_m, "max_point_range_m");
  requirePositive(p.point_sigma_m, "point_sigma_m");
  requirePositive(p.converged_step, "converged_step");
  requirePositive(p.loss_scale_m, "loss_scale_m");
  requirePositive(p.force_step, "force_step");
  requirePositive(p.moment_step, "moment_step");
  requirePositive(p.force_decay_per_m, "force_decay_per_m");
  requirePositive(p.force_cap_m, "force_cap_m");
  requirePositive(p.unobservable_sigma_m, "unobservable_sigma_m");
  requirePositive(p.unobservable_sigma_rad, "unobservable_sigma_rad");
  requirePositive(p.max_valid_cost_m, "max_valid_cost_m");
  requirePositive(p.runner_up_distinct_m, "runner_up_distinct_m");
  requirePositive(p.runner_up_distinct_rad, "runner_up_distinct_rad");
  const auto nonNegative = [](double v, const char* name) {
    if (!(std::isfinite(v) && v >= 0.0)) {
      throw std::invalid_argument(std::string("MatcherParams: ") + name + " must not be negative");
    }
  };
  nonNegative(p.correlation_length_m, "correlation_length_m");
  nonNegative(p.range_weight_m, "range_weight_m");
  nonNegative(p.runner_up_offset_m, "runner_up_offset_m");
  nonNegative(p.runner_up_offset_rad, "runner_up_offset_rad");
  nonNegative(p.sigma_floor_m, "sigma_floor_m");
  nonNegative(p.sigma_floor_rad, "sigma_floor_rad");
  nonNegative(p.camera_scale_sigma, "camera_scale_sigma");
  nonNegative(p.camera_tilt_sigma, "camera_tilt_sigma");
  nonNegative(p.camera_axis_sigma_m, "camera_axis_sigma_m");
  if (!(p.min_inlier_fraction >= 0.0 && p.min_inlier_fraction <= 1.0)) {
    throw std::invalid_argument("MatcherParams: min_inlier_fraction must be in [0, 1]");
  }
  // Off the grid then means further than the outlier distance from every line.
  if (!(std::isfinite(p.grid_margin_m) && p.grid_margin_m >= p.outlier_distance_m)) {
    throw std::invalid_argument("MatcherParams: grid_margin_m must be at least outlier_distance_m");
  }
  if (!(p.force_inertia >= 0.0 && p.force_inertia < 1.0)) {
    throw std::invalid_argument("MatcherParams: force_inertia must be in [0, 1)");
  }
  if (p.min_inliers < 3) throw std::invalid_argument("MatcherParams: min_inliers must be >= 3");
  if (p.max_iterations < 1) {
    throw std::invalid_argument("MatcherParams: max_iterations must be >= 1");
  }
}

LineGridSettings gridSettings(const MatcherParams& p) {
  return LineGridSettings{p.grid_cell_m, p.grid_margin_m, p.force_decay_per_m, p.force_cap_m};
}

// Finite points within range; the rest are skipped. With `range_weight` (m, > 0) a point at
// range r weighs 1 / (1 + (r / range_weight)^2).
void usablePoints(std::span<const perception::LinePoint> points, double max_range,
                  double range_weight, std::vector<RobotPoint>& out) {
  out.clear();
  out.reserve(points.size());
  const double max_squared = max_range * max_range;
  const double inverse_squared = range_weight > 0.0 ? 1.0 / (range_weight * range_weight) : 0.0;
  for (const perception::LinePoint& q : points) {
    const double x = q.x, y = q.y;
    if (!(std::isfinite(x) && std::isfinite(y))) continue;
    const double r2 = x * x + y * y;
    if (r2 > max_squared) continue;
    out.push_back({x, y, 1.0 / (1.0 + r2 * inverse_squared)});
  }
}

}  // namespace

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

  Linearization linearize(const std::vector<RobotPoint>& points,
                          const geometry::Pose2& pose) const {
    Linearization out;
    const double c = std::cos(pose.phi), s = std::sin(pose.phi);
    const double outlier = params.outlier_distance_m;
    const double outlier_rho = rho(outlier);
    double h00 = 0, h01 = 0, h02 = 0, h11 = 0, h12 = 0, h22 = 0, b0 = 0, b1 = 0, b2 = 0, cost = 0;
    double seed_sum = 0;
    int inliers = 0;
    // The Cauchy cost sums logs; a product of up to 64 factors (each at most
    // 1 + (outlier / scale)^2) and one log per 64 points is much cheaper and as exact.
    // (With range weights each point's cost is weighted: no product trick.)
    const bool cauchy = params.loss == RobustLoss::kCauchy && params.range_weight_m <= 0.0;
    const double inverse_scale_squared = 1.0 / (params.loss_scale_m * params.loss_scale_m);
    double cauchy_product = 1.0, cauchy_logs = 0.0;
    int in_product = 0;
    for (const RobotPoint& q : points) {
      // The point's offset from the robot in the field frame, and its field position.
      const double ox = c * q.x - s * q.y;
      const double oy = s * q.x + c * q.y;
      double d, gx, gy;
      if (!grid.distanceGradient(pose.x + ox, pose.y + oy, d, gx, gy) || d > outlier) {
        cost += q.w * outlier_rho;
        seed_sum += outlier;
        continue;
      }
      ++inliers;
      seed_sum += d;
      double w;
      if (cauchy) {
        const double t = 1.0 + d * d * inverse_scale_squared;
        w = 1.0 / t;
        cauchy_product *= t;
        if (++in_product == 64) {
          cauchy_logs += std::log(cauchy_product);
          cauchy_product = 1.0;
          in_product = 0;
        }
      } else {
        w = q.w * weight(d);
        cost += q.w * rho(d);
      }
      // d(distance)/d(x, y, phi): the gradient, and the gradient along the point's turn.
      const double j2 = gy * ox - gx * oy;
      h00 += w * gx * gx;
      h01 += w * gx * gy;
      h02 += w * gx * j2;
      h11 += w * gy * gy;
      h12 += w * gy * j2;
      h22 += w * j2 * j2;
      b0 += w * gx * d;
      b1 += w * gy * d;
      b2 += w * j2 * d;
    }
    out.information << h00, h01, h02, h01, h11, h12, h02, h12, h22;
    out.gradient << b0, b1, b2;
    if (cauchy) {
      cost += 0.5 * params.loss_scale_m * params.loss_scale_m *
              (cauchy_logs + std::log(cauchy_product));
    }
    out.robust_cost = cost;
    out.seed_sum = seed_sum;
    out.inliers = inliers;
    return out;
  }

  // Levenberg-Marquardt on the robust cost; every trial pose is linearized once, which also
  // decides whether it is accepted.
  geometry::Pose2 leastSquares(const std::vector<RobotPoint>& points, geometry::Pose2 pose,
                               int& iterations, Linearization& current) const {
    current = linearize(points, pose);
    double lambda = 1e-3;
    iterations = 0;
    while (iterations < params.max_iterations && current.inliers >= 3) {
      ++iterations;
      Eigen::Matrix3d damped = current.information;
      for (int k = 0; k < 3; ++k)
        damped(k, k) += lambda * std::max(current.information(k, k), 1e-9);
      const Eigen::Vector3d step = damped.ldlt().solve(-current.gradient);
      if (!step.allFinite()) break;
      const geometry::Pose2 trial{pose.x + step.x(), pose.y + step.y(), pose.phi + step.z()};
      Linearization next = linearize(points, trial);
      const bool small = std::hypot(step.x(), step.y()) < params.converged_step &&
                         std::abs(step.z()) < params.converged_step;
      if (next.robust_cost <= current.robust_cost) {
        // Converged when the step or the gain is negligible (the interpolated surface is only
        // piecewise smooth, so the last steps can bounce within a cell).
        const bool flat = current.robust_cost - next.robust_cost <= 1e-6 * current.robust_cost;
        pose = trial;
        current = std::move(next);
        lambda = std::max(lambda * 0.1, 1e-9);
        if (small || flat) break;
      } else {
        // Near the answer the interpolated surface is rough at the scale of its bilinear cells:
        // undamped steps of 0.5-1 mm bounce across the minimum. A rejected step that changes the
        // cost by less than that roughness is converged; otherwise damp at once to a step the
        // size of the curvature's (lambda 1), not in tenfold steps from 1e-9 (which took 8-15
        // rejected trials near the answer).
        const bool rough = next.robust_cost - current.robust_cost <= 1e-4 * current.robust_cost;
        if (small || rough || lambda > 1e8) break;
        lambda = std::max(lambda * 10.0, 1.0);
      }
    }
    return pose;
  }

  // The seed's force field (eq. 4.85-4.89): the mean force translates the cloud, the mean moment
  // about its centre of gravity turns it, until the steps vanish (with heavy-ball inertia). Points
  // further than the outlier distance from every line are discarded.
  geometry::Pose2 forceField(const std::vector<RobotPoint>& points, geometry::Pose2 pose,
                             int& iterations) const {
    const double outlier = params.outlier_distance_m;
    const double inertia_factor = params.force_inertia;
    double velocity_x = 0.0, velocity_y = 0.0, velocity_turn = 0.0;
    iterations = 0;
    while (iterations < params.max_iterations) {
      ++iterations;
      const double c = std::cos(pose.phi), s = std::sin(pose.phi);
      int n = 0;
      double sum_px = 0, sum_py = 0, sum_fx = 0, sum_fy = 0, sum_cross = 0, sum_squared = 0;
      for (const RobotPoint& q : points) {
        const double px = pose.x + c * q.x - s * q.y;
        const double py = pose.y + s * q.x + c * q.y;
        double d, fx, fy;
        if (!grid.nearestForce(px, py, d, fx, fy) || d > outlier) continue;
        ++n;
        sum_px += px;
        sum_py += py;
        sum_fx += fx;
        sum_fy += fy;
        sum_cross += px * fy - py * fx;
        sum_squared += px * px + py * py;
      }
      if (n < 3) break;
      const double gx = sum_px / n, gy = sum_py / n;
      const double force_x = sum_fx / n, force_y = sum_fy / n;
      // Moment about g: mean of (p - g) x f(p), expanded so one pass suffices.
      const double moment = sum_cross / n - (gx * force_y - gy * force_x);
      const double inertia = sum_squared / n - (gx * gx + gy * gy);
      velocity_turn = inertia_factor * velocity_turn +
                      (inertia > 1e-6 ? params.moment_step * moment / inertia : 0.0);
      velocity_x = inertia_factor * velocity_x + params.force_step * force_x;
      velocity_y = inertia_factor * velocity_y + params.force_step * force_y;
      const double turn = velocity_turn, move_x = velocity_x, move_y = velocity_y;
      // Turn the cloud about g, then move it: the robot's position follows.
      const double ct = std::cos(turn), st = std::sin(turn);
      const double rx = pose.x - gx, ry = pose.y - gy;
      pose.x = gx + ct * rx - st * ry + move_x;
      pose.y = gy + st * rx + ct * ry + move_y;
      pose.phi += turn;
      if (std::hypot(move_x, move_y) < params.converged_step &&
          std::abs(turn) < params.converged_step) {
        break;
      }
    }
    return pose;
  }

  // The seed's matching distance (eq. 4.73/4.79): mean distance, outliers at the outlier cost.
  double seedCost(const std::vector<RobotPoint>& points, const geometry::Pose2& pose,
                  int* inliers) const {
    const double outlier = params.outlier_distance_m;
    if (points.empty()) return outlier;
    const double c = std::cos(pose.phi), s = std::sin(pose.phi);
    double sum = 0.0;
    int count = 0;
    for (const RobotPoint& q : points) {
      double d;
      if (grid.distance(pose.x + c * q.x - s * q.y, pose.y + s * q.x + c * q.y, d) &&
          d <= outlier) {
        sum += d;
        ++count;
      } else {
        sum += outlier;
      }
    }
    if (inliers) *inliers = count;
    return sum / static_cast<double>(points.size());
  }

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
  void cellWeights(const std::vector<RobotPoint>& points, std::vector<double>& weights) const {
    weights.assign(points.size(), 1.0);
    const double cell = params.correlation_length_m;
    if (cell <= 0.0) return;
    std::vector<std::int64_t> keys(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      // Points lie within max_point_range_m (<= 30 m): the cell indices fit 31 bits each.
      const auto kx = static_cast<std::int64_t>(std::floor(points[i].x / cell)) + (1 << 30);
      const auto ky = static_cast<std::int64_t>(std::floor(points[i].y / cell)) + (1 << 30);
      keys[i] = (kx << 32) | ky;
    }
    std::vector<std::int64_t> sorted = keys;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto range = std::equal_range(sorted.begin(), sorted.end(), keys[i]);
      weights[i] = 1.0 / static_cast<double>(range.second - range.first);
    }
  }

  // The cell-weighted robust cost (outliers at the outlier cost).
  double weightedCost(const std::vector<RobotPoint>& points, const std::vector<double>& weights,
                      const geometry::Pose2& pose) const {
    const double c = std::cos(pose.phi), s = std::sin(pose.phi);
    const double outlier_rho = rho(params.outlier_distance_m);
    double sum = 0.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const RobotPoint& q = points[i];
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
                          const geometry::Pose2& pose) const {
    WeightedFit out;
    const double c = std::cos(pose.phi), s = std::sin(pose.phi);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const RobotPoint& q = points[i];
      const double ox = c * q.x - s * q.y;
      const double oy = s * q.x + c * q.y;
      double d, gx, gy;
      if (!grid.distanceGradient(pose.x + ox, pose.y + oy, d, gx, gy) ||
          d > params.outlier_distance_m) {
        continue;
      }
      const double w = weights[i] * q.w * weight(d);
      const Eigen::Vector3d j(gx, gy, gy * ox - gx * oy);
      out.information += w * j * j.transpose();
      out.weight_sum += w;
      out.weighted_squares += w * d * d;
      out.independent += weights[i];
      // A longer distance function moves the point outward along its ray: the distance changes
      // by the gradient along the offset; a tilt does so by the cosine of the bearing.
      const double radial = gx * ox + gy * oy;
      const double range = std::hypot(q.x, q.y);
      out.scale += w * radial * j;
      if (range > 0.0) {
        out.tilt_cos += w * radial * (q.x / range) * j;
        out.tilt_sin += w * radial * (q.y / range) * j;
      }
    }
    return out;
  }

  // The camera's calibration errors (MatcherParams::camera_*), through the fit: a parameter
  // error e moves the answer by -H^-1 J^T W (dd/de) e, whatever the residuals say.
  void addCameraErrors(const WeightedFit& fit, double scale, const Eigen::Matrix3d& prior,
                       Eigen::Matrix3d& covariance) const {
    const Eigen::LDLT<Eigen::Matrix3d> solver(fit.information + scale * prior);
    const auto addResponse = [&](const Eigen::Vector3d& b, double sigma) {
      if (sigma <= 0.0) return;
      const Eigen::Vector3d response = solver.solve(b);
      if (response.allFinite()) covariance += sigma * sigma * response * response.transpose();
    };
    addResponse(fit.scale, params.camera_scale_sigma);
    addResponse(fit.tilt_cos, params.camera_tilt_sigma);
    addResponse(fit.tilt_sin, params.camera_tilt_sigma);
    // The axis's offset moves every point alike: the robot's position by as much.
    covariance(0, 0) += params.camera_axis_sigma_m * params.camera_axis_sigma_m;
    covariance(1, 1) += params.camera_axis_sigma_m * params.camera_axis_sigma_m;
  }

  // The covariance from the shape of the cost at `pose` (see the header); fills the diagnostics
  // of `out`.
  Eigen::Matrix3d shapeCovariance(const std::vector<RobotPoint>& points,
                                  const std::vector<double>& weights, const geometry::Pose2& pose,
                                  PoseCorrection& out) const {
    const WeightedFit fit = weightedFit(points, weights, pose);
    const double point_variance = params.point_sigma_m * params.point_sigma_m;
    // Residual variance of a group, with the three fitted parameters taken out.
    double residual_variance = point_variance;
    if (fit.weight_sum > 0.0) {
      const double dof = fit.independent > 4.0 ? fit.independent / (fit.independent - 3.0) : 4.0;
      residual_variance = fit.weighted_squares / fit.weight_sum * dof;
    }
    const double inflation = std::max(1.0, residual_variance / point_variance);
    out.residual_rms_m = fit.weight_sum > 0.0 ? std::sqrt(fit.weighted_squares / fit.weight_sum)
                                              : params.outlier_distance_m;
    out.residual_inflation = inflation;
    out.independent_points = fit.independent;
    const double scale = point_variance * inflation;
    const Eigen::Matrix3d data = fit.information / scale;
    Eigen::Matrix3d prior = Eigen::Matrix3d::Zero();
    prior(0, 0) = prior(1, 1) = 1.0 / (params.unobservable_sigma_m * params.unobservable_sigma_m);
    prior(2, 2) = 1.0 / (params.unobservable_sigma_rad * params.unobservable_sigma_rad);
    Eigen::Matrix3d covariance = (data + prior).inverse();
    covariance = 0.5 * (covariance + covariance.transpose()).eval();
    out.shape_widening = 1.0;
    if (!params.shape_check || !covariance.allFinite()) {
      addCameraErrors(fit, scale, prior, covariance);
      return 0.5 * (covariance + covariance.transpose()).eval();
    }

    // Along each axis: the cost 1.5 and 3 sigmas out, against the quadratic's t^2 / 2 (the cost
    // in units of the point model is half a chi-square). Where it rises less, the axis widens
    // (by at most 20 in sigma). An axis only the prior holds is wide already.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
    Eigen::Vector3d variances = eigen.eigenvalues();
    const double base = weightedCost(points, weights, pose) / scale;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d axis = eigen.eigenvectors().col(k);
      if (axis.dot(data * axis) < axis.dot(prior * axis) || !(variances[k] > 0.0)) continue;
      const Eigen::Vector3d step = std::sqrt(variances[k]) * axis;
      double ratio = 1.0;
      for (const double t : {1.5, 3.0}) {
        for (const double sign : {-1.0, 1.0}) {
          const geometry::Pose2 probe{pose.x + sign * t * step.x(), pose.y + sign * t * step.y(),
                                      pose.phi + sign * t * step.z()};
          const double rise = weightedCost(points, weights, probe) / scale - base;
          ratio = std::min(ratio, rise / (0.5 * t * t));
        }
      }
      const double widening = 1.0 / std::max(ratio, 1.0 / 400.0);
      variances[k] *= widening;
      out.shape_widening = std::max(out.shape_widening, widening);
    }
    covariance = eigen.eigenvectors() * variances.asDiagonal() * eigen.eigenvectors().transpose();
    addCameraErrors(fit, scale, prior, covariance);
    return 0.5 * (covariance + covariance.transpose()).eval();
  }

  // The full answer from `guess`: the fit, the runner-up search, the covariance. With `analyse`
  // false only the fit and a Hessian covariance (the global search's lattice refinement).
  PoseCorrection correct(const std::vector<RobotPoint>& points, const geometry::Pose2& guess,
                         std::int64_t utime, bool analyse = true) const {
    PoseCorrection out;
    out.utime = utime;
    out.pose = guess;
    out.points_used = static_cast<int>(points.size());
    if (!geometry::isFinite(guess)) {
      out.cost = params.outlier_distance_m;
      out.invalid_reason = "the guess is not finite";
      return out;
    }
    Linearization at;
    geometry::Pose2 pose = optimize(points, guess, out.iterations, at);

    // The runner-up: the fit restarted around the answer; a better minimum becomes the answer.
    struct Minimum {
      geometry::Pose2 pose;
      Linearization at;
    };
    std::optional<Minimum> runner;
    const bool search = analyse && points.size() >= 3 &&
                        (params.runner_up_offset_m > 0.0 || params.runner_up_offset_rad > 0.0);
    if (search) {
      Eigen::Matrix2d position = Eigen::Matrix2d::Identity();
      if (at.information.allFinite()) {
        const Eigen::Matrix3d h = at.information + 1e-9 * Eigen::Matrix3d::Identity();
        const Eigen::Matrix3d inverse = h.inverse();
        if (inverse.allFinite()) position = inverse.topLeftCorner<2, 2>();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> axes(position);
      std::vector<Eigen::Vector3d> offsets;
      for (int k = 1; k >= 0 && params.runner_up_offset_m > 0.0; --k) {
        const Eigen::Vector2d a = axes.eigenvectors().col(k) * params.runner_up_offset_m;
        offsets.emplace_back(a.x(), a.y(), 0.0);
        offsets.emplace_back(-a.x(), -a.y(), 0.0);
      }
      if (params.runner_up_offset_rad > 0.0) {
        offsets.emplace_back(0.0, 0.0, params.runner_up_offset_rad);
        offsets.emplace_back(0.0, 0.0, -params.runner_up_offset_rad);
      }
      const auto distinct = [this](const geometry::Pose2& a, const geometry::Pose2& b) {
        return std::hypot(a.x - b.x, a.y - b.y) > params.runner_up_distinct_m ||
               std::abs(geometry::angleDiff(a.phi, b.phi)) > params.runner_up_distinct_rad;
      };
      std::vector<Minimum> found;
      for (const Eigen::Vector3d& o : offsets) {
        int iterations = 0;
        Minimum m;
        m.pose =
            optimize(points, {pose.x + o.x(), pose.y + o.y(), pose.phi + o.z()}, iterations, m.at);
        if (!distinct(m.pose, pose)) continue;
        const bool known = std::any_of(found.begin(), found.end(),
                                       [&](const Minimum& f) { return !distinct(f.pose, m.pose); });
        if (!known) found.push_back(std::move(m));
      }
      if (!found.empty()) {
        auto best = std::min_element(found.begin(), found.end(), [](const auto& a, const auto& b) {
          return a.at.robust_cost < b.at.robust_cost;
        });
        if (best->at.robust_cost < at.robust_cost) {
          // A better fit: the answer moves there, the old answer is a candidate runner-up.
          Minimum old{pose, at};
          pose = best->pose;
          at = best->at;
          *best = std::move(old);
        }
        runner = *std::min_element(found.begin(), found.end(), [](const auto& a, const auto& b) {
          return a.at.robust_cost < b.at.robust_cost;
        });
      }
    }

    out.pose = pose;
    out.inliers = at.inliers;
    out.cost = points.empty() ? params.outlier_distance_m
                              : at.seed_sum / static_cast<double>(points.size());

    Eigen::Matrix3d covariance;
    if (analyse) {
      std::vector<double> weights;
      cellWeights(points, weights);
      covariance = shapeCovariance(points, weights, pose, out);
      if (runner) {
        // The runner-up by its likelihood against the answer's: the second moment about the
        // answer of the two as a mixture.
        const double scale = params.point_sigma_m * params.point_sigma_m * out.residual_inflation;
        const double delta = std::max(0.0, (weightedCost(points, weights, runner->pose) -
                                            weightedCost(points, weights, pose)) /
                                               scale);
        const double share = 1.0 / (1.0 + std::exp(std::min(delta, 700.0)));
        const Eigen::Vector3d apart(runner->pose.x - pose.x, runner->pose.y - pose.y,
                                    geometry::angleDiff(runner->pose.phi, pose.phi));
        covariance += share * apart * apart.transpose();
        out.has_runner_up = true;
        out.runner_up = runner->pose;
        out.runner_up.phi = geometry::normalizeAngle(out.runner_up.phi);
        out.runner_up_cost = runner->at.seed_sum / static_cast<double>(points.size());
        out.runner_up_delta = delta;
      }
    } else {
      // Sigma^2 (J^T W J)^-1 with a weak prior in the directions the points do not constrain.
      const double point_variance = params.point_sigma_m * params.point_sigma_m;
      Eigen::Matrix3d information = at.information / point_variance;
      information(0, 0) += 1.0 / (params.unobservable_sigma_m * params.unobservable_sigma_m);
      information(1, 1) += 1.0 / (params.unobservable_sigma_m * params.unobservable_sigma_m);
      information(2, 2) += 1.0 / (params.unobservable_sigma_rad * params.unobservable_sigma_rad);
      covariance = information.inverse();
    }
    covariance(0, 0) += params.sigma_floor_m * params.sigma_floor_m;
    covariance(1, 1) += params.sigma_floor_m * params.sigma_floor_m;
    covariance(2, 2) += params.sigma_floor_rad * params.sigma_floor_rad;
    out.covariance = 0.5 * (covariance + covariance.transpose()).eval();
    const bool positive = out.covariance.allFinite() &&
                          Eigen::LLT<Eigen::Matrix3d>(out.covariance).info() == Eigen::Success;
    if (!positive) {
      out.invalid_reason = "no positive definite covariance";
    } else if (!geometry::isFinite(pose)) {
      out.invalid_reason = "the fit diverged";
    } else if (out.inliers < params.min_inliers) {
      out.invalid_reason = "too few points near a line (" + std::to_string(out.inliers) + " < " +
                           std::to_string(params.min_inliers) + ")";
    } else if (out.inliers < params.min_inlier_fraction * out.points_used) {
      out.invalid_reason = "too few of the points near a line (" + std::to_string(out.inliers) +
                           " of " + std::to_string(out.points_used) + ")";
    } else if (out.cost > params.max_valid_cost_m) {
      out.invalid_reason = "mean matching cost " + std::to_string(out.cost) + " m above " +
                           std::to_string(params.max_valid_cost_m) + " m";
    }
    out.valid = out.invalid_reason.empty();
    if (!positive) out.covariance = Eigen::Matrix3d::Identity();
    return out;
  }
};

LineMatcher::LineMatcher(const field::FieldModel& field, MatcherParams params,
                         const std::string& cache_dir)
    : impl_(std::make_unique<Impl>()) {
  validate(params);
  impl_->params = params;
  GridSource how = GridSource::kBuilt;
  std::string problem;
  impl_->grid = loadOrBuildLineGrid(field, gridSettings(params), cache_dir, &how, &problem);
  switch (how) {
    case GridSource::kLoadedFromCache:
      impl_->source = "loaded";
      break;
    case GridSource::kBuilt:
      impl_->source = "built";
      break;
    case GridSource::kRebuiltBadCache:
      impl_->source = "rebuilt: " + problem;
      break;
  }
  impl_->carpet_half = field.carpetHalfExtent();
  impl_->buildCoarse();
}

LineMatcher::~LineMatcher() = default;
LineMatcher::LineMatcher(LineMatcher&&) noexcept = default;
LineMatcher& LineMatcher::operator=(LineMatcher&&) noexcept = default;

const MatcherParams& LineMatcher::params() const {
  return impl_->params;
}
const std::string& LineMatcher::gridSource() const {
  return impl_->source;
}

PoseCorrection LineMatcher::correct(std::span<const perception::LinePoint> points,
                                    const geometry::Pose2& guess, std::int64_t utime) const {
  std::vector<RobotPoint> usable;
  usablePoints(points, impl_->params.max_point_range_m, impl_->params.range_weight_m, usable);
  return impl_->correct(usable, guess, utime);
}

double LineMatcher::cost(std::span<const perception::LinePoint> points,
                         const geometry::Pose2& pose) const {
  std::vector<RobotPoint> usable;
  usablePoints(points, impl_->params.max_point_range_m, impl_->params.range_weight_m, usable);
  if (!geometry::isFinite(pose)) return impl_->params.outlier_distance_m;
  return impl_->seedCost(usable, pose, nullptr);
}

std::vector<PoseCorrection> LineMatcher::globalSearch(std::span<const perception::LinePoint> points,
                                                      const GlobalSearchParams& search,
                                                      std::int64_t utime,
                                                      PoseCorrection* best_rejected) const {
  const Impl& m = *impl_;
  if (!(std::isfinite(search.position_step_m) && search.position_step_m >= 0.05 &&
        std::isfinite(search.heading_step_rad) && search.heading_step_rad >= 0.005 &&
        search.scoring_points >= 3 && search.refined >= 1 && search.max_results >= 1)) {
    throw std::invalid_argument("GlobalSearchParams: steps too small or counts below one");
  }
  std::vector<RobotPoint> usable;
  usablePoints(points, m.params.max_point_range_m, m.params.range_weight_m, usable);
  if (best_rejected) {
    *best_rejected = PoseCorrection{};
    best_rejected->points_used = static_cast<int>(usable.size());
    best_rejected->cost = m.params.outlier_distance_m;
    best_rejected->invalid_reason =
        "fewer usable points (" + std::to_string(usable.size()) + ") than min_inliers";
  }
  if (static_cast<int>(usable.size()) < m.params.min_inliers) return {};

  // Score the lattice with an even subsample: the seed's cost, outliers at the outlier distance.
  std::vector<RobotPoint> scoring;
  const std::size_t stride =
      std::max<std::size_t>(1, usable.size() / static_cast<std::size_t>(search.scoring_points));
  for (std::size_t k = 0; k < usable.size(); k += stride)
    scoring.push_back(usable[k]);
  const int headings =
      std::max(1, static_cast<int>(std::ceil(2.0 * std::numbers::pi / search.heading_step_rad)));
  const int columns = static_cast<int>(2.0 * m.carpet_half.x() / search.position_step_m) + 1;
  const int rows = static_cast<int>(2.0 * m.carpet_half.y() / search.position_step_m) + 1;
  // Centre the lattice on the field so it is as symmetric as the field.
  const double x0 = -0.5 * (columns - 1) * search.position_step_m;
  const double y0 = -0.5 * (rows - 1) * search.position_step_m;
  using Scored = std::pair<double, geometry::Pose2>;
  auto worse = [](const Scored& a, const Scored& b) { return a.first < b.first; };
  // Max-heap of the best `refined` lattice poses: the worst kept one on top.
  std::priority_queue<Scored, std::vector<Scored>, decltype(worse)> best(worse);
  std::vector<RobotPoint> turned(scoring.size());
  for (int h = 0; h < headings; ++h) {
    const double phi = geometry::normalizeAngle(h * 2.0 * std::numbers::pi / headings);
    const double c = std::cos(phi), s = std::sin(phi);
    for (std::size_t k = 0; k < scoring.size(); ++k) {
      turned[k] = {c * scoring[k].x - s * scoring[k].y, s * scoring[k].x + c * scoring[k].y};
    }
    for (int j = 0; j < rows; ++j) {
      const double y = y0 + j * search.position_step_m;
      for (int i = 0; i < columns; ++i) {
        const double x = x0 + i * search.position_step_m;
        const double bound = best.size() == static_cast<std::size_t>(search.refined)
                                 ? best.top().first
                                 : std::numeric_limits<double>::infinity();
        double sum = 0.0;
        for (const RobotPoint& q : turned) {
          sum += m.coarseDistance(x + q.x, y + q.y);
          if (sum >= bound) break;  // cannot enter the kept set any more
        }
        if (sum >= bound) continue;
        best.push({sum, geometry::Pose2{x, y, phi}});
        if (best.size() > static_cast<std::size_t>(search.refined)) best.pop();
      }
    }
  }

  std::vector<PoseCorrection> refined;
  while (!best.empty()) {
    PoseCorrection c = m.correct(usable, best.top().second, utime, false);
    best.pop();
    if (c.valid) {
      refined.push_back(c);
    } else if (best_rejected && (best_rejected->iterations == 0 || c.cost < best_rejected->cost)) {
      *best_rejected = c;
    }
  }
  std::sort(refined.begin(), refined.end(),
            [](const PoseCorrection& a, const PoseCorrection& b) { return a.cost < b.cost; });
  std::vector<PoseCorrection> distinct;
  for (const PoseCorrection& c : refined) {
    const bool seen = std::any_of(distinct.begin(), distinct.end(), [&](const PoseCorrection& d) {
      return std::hypot(c.pose.x - d.pose.x, c.pose.y - d.pose.y) < search.distinct_m &&
             std::abs(geometry::angleDiff(c.pose.phi, d.pose.phi)) < search.distinct_rad;
    });
    if (!seen) distinct.push_back(c);
    if (static_cast<int>(distinct.size()) >= search.max_results) break;
  }
  // The answers with their full analysis (runner-up, shape of the cost), from where they are.
  std::vector<PoseCorrection> analysed;
  for (const PoseCorrection& c : distinct) {
    PoseCorrection full = m.correct(usable, c.pose, utime);
    if (full.valid) {
      analysed.push_back(full);
    } else if (best_rejected && full.cost < best_rejected->cost) {
      *best_rejected = full;
    }
  }
  std::sort(analysed.begin(), analysed.end(),
            [](const PoseCorrection& a, const PoseCorrection& b) { return a.cost < b.cost; });
  // Two answers whose runner-up search moved them to the same place are one.
  std::vector<PoseCorrection> out;
  for (const PoseCorrection& c : analysed) {
    const bool seen = std::any_of(out.begin(), out.end(), [&](const PoseCorrection& d) {
      return std::hypot(c.pose.x - d.pose.x, c.pose.y - d.pose.y) < search.distinct_m &&
             std::abs(geometry::angleDiff(c.pose.phi, d.pose.phi)) < search.distinct_rad;
    });
    if (!seen) out.push_back(c);
  }
  // The best refused pose as fully analysed as an answer (its covariance from the shape of the
  // cost, not the lattice refinement's Hessian): a user judges it by these figures.
  if (best_rejected && best_rejected->iterations > 0 && best_rejected->independent_points == 0.0) {
    const PoseCorrection full = m.correct(usable, best_rejected->pose, utime);
    // (Its runner-up search can move it to a place that fits: that one is no refusal.)
    if (!full.valid) *best_rejected = full;
  }
  return out;
}

}  // namespace fieldline::fusion
