// Layer 2's settings (MatcherParams): their check and their loader.
#include <cmath>
#include <stdexcept>
#include <string>

#include "services/fusion/line_matcher_impl.hpp"

namespace fieldline::fusion {
namespace {

void requirePositive(double value, const char* name) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw std::invalid_argument(std::string("MatcherParams: ") + name + " must be positive");
  }
}

}  // namespace

void validateMatcherParams(const MatcherParams& p) {
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

MatcherParams loadMatcherParams(const config::Node& n) {
  MatcherParams p;
  if (n.has("method")) {
    p.method = n.getChoice("method", {"force_field", "least_squares"}) == "force_field"
                   ? MatchMethod::kForceField
                   : MatchMethod::kRobustLeastSquares;
  }
  if (n.has("loss")) {
    p.loss = n.getChoice("loss", {"huber", "cauchy"}) == "huber" ? RobustLoss::kHuber
                                                                 : RobustLoss::kCauchy;
  }
  p.grid_cell_m = n.getOr<double>("grid_cell_m", p.grid_cell_m, 0.005, 0.5);
  p.grid_margin_m = n.getOr<double>("grid_margin_m", p.grid_margin_m, 0.0, 5.0);
  p.outlier_distance_m = n.getOr<double>("outlier_distance_m", p.outlier_distance_m, 0.01, 2.0);
  p.max_point_range_m = n.getOr<double>("max_point_range_m", p.max_point_range_m, 0.1, 30.0);
  p.point_sigma_m = n.getOr<double>("point_sigma_m", p.point_sigma_m, 1e-4, 1.0);
  p.correlation_length_m =
      n.getOr<double>("correlation_length_m", p.correlation_length_m, 0.0, 5.0);
  p.range_weight_m = n.getOr<double>("range_weight_m", p.range_weight_m, 0.0, 100.0);
  p.camera_scale_sigma = n.getOr<double>("camera_scale_sigma", p.camera_scale_sigma, 0.0, 0.5);
  p.camera_tilt_sigma = n.getOr<double>("camera_tilt_sigma", p.camera_tilt_sigma, 0.0, 0.5);
  p.camera_axis_sigma_m = n.getOr<double>("camera_axis_sigma_m", p.camera_axis_sigma_m, 0.0, 1.0);
  p.min_inliers = n.getOr<int>("min_inliers", p.min_inliers, 3, 100000);
  p.min_inlier_fraction = n.getOr<double>("min_inlier_fraction", p.min_inlier_fraction, 0.0, 1.0);
  p.max_valid_cost_m = n.getOr<double>("max_valid_cost_m", p.max_valid_cost_m, 0.001, 10.0);
  p.runner_up_offset_m = n.getOr<double>("runner_up_offset_m", p.runner_up_offset_m, 0.0, 5.0);
  p.runner_up_offset_rad =
      n.getOr<double>("runner_up_offset_rad", p.runner_up_offset_rad, 0.0, 3.2);
  p.runner_up_distinct_m =
      n.getOr<double>("runner_up_distinct_m", p.runner_up_distinct_m, 1e-3, 5.0);
  p.runner_up_distinct_rad =
      n.getOr<double>("runner_up_distinct_rad", p.runner_up_distinct_rad, 1e-3, 3.2);
  p.shape_check = n.getOr<bool>("shape_check", p.shape_check);
  p.sigma_floor_m = n.getOr<double>("sigma_floor_m", p.sigma_floor_m, 0.0, 1.0);
  p.sigma_floor_rad = n.getOr<double>("sigma_floor_rad", p.sigma_floor_rad, 0.0, 1.0);
  p.max_iterations = n.getOr<int>("max_iterations", p.max_iterations, 1, 10000);
  p.converged_step = n.getOr<double>("converged_step", p.converged_step, 1e-9, 0.1);
  p.loss_scale_m = n.getOr<double>("loss_scale_m", p.loss_scale_m, 1e-3, 2.0);
  p.force_step = n.getOr<double>("force_step", p.force_step, 1e-3, 2.0);
  p.moment_step = n.getOr<double>("moment_step", p.moment_step, 1e-3, 2.0);
  p.force_inertia = n.getOr<double>("force_inertia", p.force_inertia, 0.0, 0.99);
  p.force_decay_per_m = n.getOr<double>("force_decay_per_m", p.force_decay_per_m, 0.01, 1000.0);
  p.force_cap_m = n.getOr<double>("force_cap_m", p.force_cap_m, 0.01, 10.0);
  p.unobservable_sigma_m =
      n.getOr<double>("unobservable_sigma_m", p.unobservable_sigma_m, 0.01, 1000.0);
  p.unobservable_sigma_rad =
      n.getOr<double>("unobservable_sigma_rad", p.unobservable_sigma_rad, 0.001, 100.0);
  n.rejectUnknownKeys();
  if (p.grid_margin_m < p.outlier_distance_m) {
    throw config::Error(n.file() + ":" + std::to_string(n.line()) + ": " + n.path() +
                        ": grid_margin_m must be at least outlier_distance_m");
  }
  return p;
}

}  // namespace fieldline::fusion
