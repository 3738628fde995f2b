// Layer 2's settings (MatcherParams): their check (the loader is fusion_config.cpp's declaration).
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

}  // namespace fieldline::fusion
