// Layer 2's answer from a guess (line_matcher.hpp): the fit, the runner-up search, the covariance
// from the cost's shape and the camera's calibration errors, and the answer's validity.
#include "services/fusion/line_matcher_impl.hpp"

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

namespace fieldline::fusion {

void LineMatcher::Impl::cellWeights(const std::vector<RobotPoint>& points,
                                    std::vector<double>& weights) const {
  weights.assign(points.size(), 1.0);
  const double cell = params.correlation_length_m;
  if (cell <= 0.0) return;
  // The points sorted by cell (their indices along): each run of one cell gives its points
  // 1 / (its length), the count an equal_range per point found before.
  std::vector<std::pair<std::int64_t, std::uint32_t>> keyed(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    // Points lie within max_point_range_m (<= 30 m): the cell indices fit 31 bits each.
    const auto kx = static_cast<std::int64_t>(std::floor(points[i].x / cell)) + (1 << 30);
    const auto ky = static_cast<std::int64_t>(std::floor(points[i].y / cell)) + (1 << 30);
    keyed[i] = {(kx << 32) | ky, static_cast<std::uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t a = 0; a < keyed.size();) {
    std::size_t b = a + 1;
    while (b < keyed.size() && keyed[b].first == keyed[a].first)
      ++b;
    const double w = 1.0 / static_cast<double>(b - a);
    for (std::size_t k = a; k < b; ++k)
      weights[keyed[k].second] = w;
    a = b;
  }
}

LineMatcher::Impl::WeightedFit LineMatcher::Impl::weightedFit(const std::vector<RobotPoint>& points,
                                                              const std::vector<double>& weights,
                                                              const geometry::Pose2& pose) const {
  WeightedFit out;
  const double c = std::cos(pose.phi), s = std::sin(pose.phi);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const RobotPoint& q = points[i];
    if (i + kPrefetchAhead < points.size()) prefetchAt(points[i + kPrefetchAhead], pose, c, s);
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

void LineMatcher::Impl::addCameraErrors(const WeightedFit& fit, double scale,
                                        const Eigen::Matrix3d& prior,
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

Eigen::Matrix3d LineMatcher::Impl::shapeCovariance(const std::vector<RobotPoint>& points,
                                                   const std::vector<double>& weights,
                                                   const geometry::Pose2& pose, PoseCorrection& out,
                                                   std::optional<double>& cost_at_pose) const {
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
  cost_at_pose = weightedCost(points, weights, pose);
  const double base = *cost_at_pose / scale;
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

std::optional<LineMatcher::Impl::Minimum> LineMatcher::Impl::searchRunnerUp(
    const std::vector<RobotPoint>& points, geometry::Pose2& pose, Linearization& at) const {
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
    m.pose = optimize(points, {pose.x + o.x(), pose.y + o.y(), pose.phi + o.z()}, iterations, m.at);
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
    return *std::min_element(found.begin(), found.end(), [](const auto& a, const auto& b) {
      return a.at.robust_cost < b.at.robust_cost;
    });
  }
  return std::nullopt;
}

std::string LineMatcher::Impl::invalidReason(const PoseCorrection& out, const geometry::Pose2& pose,
                                             bool positive) const {
  if (!positive) {
    return "no positive definite covariance";
  } else if (!geometry::isFinite(pose)) {
    return "the fit diverged";
  } else if (out.inliers < params.min_inliers) {
    return "too few points near a line (" + std::to_string(out.inliers) + " < " +
           std::to_string(params.min_inliers) + ")";
  } else if (out.inliers < params.min_inlier_fraction * out.points_used) {
    return "too few of the points near a line (" + std::to_string(out.inliers) + " of " +
           std::to_string(out.points_used) + ")";
  } else if (out.cost > params.max_valid_cost_m) {
    return "mean matching cost " + std::to_string(out.cost) + " m above " +
           std::to_string(params.max_valid_cost_m) + " m";
  }
  return {};
}

PoseCorrection LineMatcher::Impl::correct(const std::vector<RobotPoint>& points,
                                          const geometry::Pose2& guess, std::int64_t utime,
                                          bool analyse) const {
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
  const bool search = analyse && points.size() >= 3 &&
                      (params.runner_up_offset_m > 0.0 || params.runner_up_offset_rad > 0.0);
  const std::optional<Minimum> runner =
      search ? searchRunnerUp(points, pose, at) : std::optional<Minimum>();

  out.pose = pose;
  out.inliers = at.inliers;
  out.cost =
      points.empty() ? params.outlier_distance_m : at.seed_sum / static_cast<double>(points.size());

  Eigen::Matrix3d covariance;
  if (analyse) {
    std::vector<double> weights;
    cellWeights(points, weights);
    std::optional<double> cost_at_pose;
    covariance = shapeCovariance(points, weights, pose, out, cost_at_pose);
    if (runner) {
      // The runner-up by its likelihood against the answer's: the second moment about the
      // answer of the two as a mixture.
      const double scale = params.point_sigma_m * params.point_sigma_m * out.residual_inflation;
      // (The cost at the answer as the shape check took it, when it did: the same figure.)
      if (!cost_at_pose) cost_at_pose = weightedCost(points, weights, pose);
      const double delta =
          std::max(0.0, (weightedCost(points, weights, runner->pose) - *cost_at_pose) / scale);
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
  out.invalid_reason = invalidReason(out, pose, positive);
  out.valid = out.invalid_reason.empty();
  if (!positive) out.covariance = Eigen::Matrix3d::Identity();
  return out;
}

}  // namespace fieldline::fusion
