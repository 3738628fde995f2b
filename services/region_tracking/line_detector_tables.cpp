// The line detector's tables, built once per camera: which pixels have a floor point, the
// longest line run per block of pixels, the walks along quantised normals, the smoothing kernel
// and the floor's Jacobian at every cell corner.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "services/region_tracking/detector_pixels.hpp"
#include "services/region_tracking/line_detector.hpp"

namespace fieldline::region_tracking {

using detail::kCornerToPixel;
using detail::kNaN;

namespace {
void checkParams(const LineDetectorParams& p, int cell_size) {
  if (p.sample_spacing < 1 || p.tangent_half_span < 1 || p.smoothing_passes < 0 ||
      p.max_transition_pixels < 0 || p.max_gap_pixels < 0 || p.field_confirm_pixels < 1 ||
      cell_size < 1 || !(p.ridge_contrast == 0.0 || p.ridge_contrast >= 1.0) ||
      p.ridge_min_levels < 0 || p.ridge_min_levels > 255 ||
      !(p.sample_spacing_m >= 0.0 && p.sample_spacing_m <= 10.0) ||
      !(p.sample_min_px >= 0.25 && p.sample_min_px <= 1000.0) ||
      !(p.turn_spacing_m >= 0.0 && p.turn_spacing_m <= 10.0) ||
      !(p.turn_reach_m >= 0.0 && p.turn_reach_m <= 100.0) ||
      !(p.turn_range_m >= 0.0 && p.turn_range_m <= 100.0) ||
      !(p.turn_angle > 0.0 && p.turn_angle <= 1.5) || p.turn_span < 1 || p.turn_span > 100 ||
      !(p.refine_range_m >= 0.0 && p.refine_range_m <= 100.0) ||
      !(p.refine_min_range_m >= 0.0 && p.refine_min_range_m <= 100.0) ||
      !(p.refine_spacing_m >= 0.0 && p.refine_spacing_m <= 10.0) || p.refine_samples < 1 ||
      p.refine_samples > 64 || p.refine_reach < 1 || p.refine_reach > 16 ||
      !(p.refine_turn > 0.0 && p.refine_turn <= 3.1)) {
    throw std::invalid_argument("line detector: invalid parameters");
  }
}
}  // namespace

LineDetector::LineDetector(const camera::ColourTable& table, const FloorLookup& floor,
                           const LineDetectorParams& params, int cell_size)
    : LineDetector(std::make_shared<const ClassLookup>(table), floor, params, cell_size) {}

LineDetector::LineDetector(const ClassLookup& lookup, const FloorLookup& floor,
                           const LineDetectorParams& params, int cell_size)
    // Not owned: the aliasing constructor with no owner.
    : LineDetector(
          std::shared_ptr<const ClassLookup>(std::shared_ptr<const ClassLookup>(), &lookup), floor,
          params, cell_size) {}

LineDetector::LineDetector(std::shared_ptr<const ClassLookup> lookup, const FloorLookup& floor,
                           const LineDetectorParams& params, int cell_size)
    : lookup_(std::move(lookup)),
      floor_(floor),
      params_(params),
      cell_size_(cell_size),
      usable_words_per_row_((floor.width() + 63) / 64),
      usable_(static_cast<std::size_t>(usable_words_per_row_) * floor.height(), 0),
      run_blocks_per_row_((floor.width() >> kRunBlockShift) + 1),
      max_run_by_block_(
          static_cast<std::size_t>(run_blocks_per_row_) * ((floor.height() >> kRunBlockShift) + 1),
          0),
      // Half a cell inside the boundary (at least 2 px): the field pixels before the line.
      first_step_(-std::max(2, cell_size / 2)) {
  checkParams(params_, cell_size);
  const int longestRun = buildRunTables();
  last_step_ =
      cell_size_ + longestRun + 2 * params_.max_transition_pixels + params_.field_confirm_pixels;
  stop_step_base_ =
      cell_size_ + 2 * params_.max_transition_pixels + params_.field_confirm_pixels - first_step_;
  probe_step_ = cell_size_ + 1 - first_step_;
  buildWalks();
  buildSmoothingKernel();
  buildJacobians();
}

int LineDetector::buildRunTables() {
  // The longest white run a line can give at a pixel: its width at the pixel's finest floor
  // resolution, with tolerance, + 2 px; capped so that walks fit the 8-bit steps (~110 px).
  const int runCap =
      127 - cell_size_ - 2 * params_.max_transition_pixels - params_.field_confirm_pixels - 1;
  if (runCap < 3 || first_step_ < -127) {
    throw std::invalid_argument("line detector: cells or transitions too large");
  }
  int longestRun = 0;
  for (int v = 0; v < floor_.height(); ++v) {
    for (int u = 0; u < floor_.width(); ++u) {
      const float metresPerPixel = floor_.finestMetresPerPixel(u, v);
      if (!std::isfinite(metresPerPixel) || metresPerPixel <= 0.0f) continue;
      usable_[static_cast<std::size_t>(v) * usable_words_per_row_ + (u >> 6)] |= std::uint64_t{1}
                                                                                 << (u & 63);
      const double run = params_.width_tolerance * params_.line_width / metresPerPixel + 2;
      const int capped = static_cast<int>(std::min(run, static_cast<double>(runCap)));
      std::uint8_t& block =
          max_run_by_block_[static_cast<std::size_t>(v >> kRunBlockShift) * run_blocks_per_row_ +
                            (u >> kRunBlockShift)];
      block = static_cast<std::uint8_t>(std::max<int>(block, capped));
      longestRun = std::max(longestRun, capped);
    }
  }
  return longestRun;
}

void LineDetector::buildWalks() {
  // The walks: nearest pixel to t * normal for t = first_step_..last_step_, repeats dropped.
  const int span = last_step_ - first_step_ + 1;
  walk_capacity_ = span;
  walks_.assign(static_cast<std::size_t>(kDirections) * span, Step{0, 0});
  walk_count_up_to_.assign(static_cast<std::size_t>(kDirections) * span, 0);
  for (int d = 0; d < kDirections; ++d) {
    // The middle of the direction's bin on the "diamond" |u| + |v| = 1 (see directionOf).
    const double p = (d + 0.5) * 4.0 / kDirections;
    const int quadrant = static_cast<int>(p);
    const double r = p - quadrant;
    double nu = 1 - r, nv = r;
    for (int q = 0; q < quadrant; ++q) {
      const double turned = -nv;  // 90 degrees, +u towards +v
      nv = nu;
      nu = turned;
    }
    const double norm = std::hypot(nu, nv);
    nu /= norm;
    nv /= norm;
    Step* walk = &walks_[static_cast<std::size_t>(d) * span];
    std::uint8_t* countUpTo = &walk_count_up_to_[static_cast<std::size_t>(d) * span];
    int count = 0;
    for (int t = first_step_; t <= last_step_; ++t) {
      const Step step{static_cast<std::int8_t>(std::floor(t * nu + 0.5)),
                      static_cast<std::int8_t>(std::floor(t * nv + 0.5))};
      if (count == 0 || step.du != walk[count - 1].du || step.dv != walk[count - 1].dv) {
        walk[count++] = step;
      }
      countUpTo[t - first_step_] = static_cast<std::uint8_t>(count);
    }
    probes_[d] = walk[countUpTo[probe_step_] - 1];
  }
}

void LineDetector::buildSmoothingKernel() {
  // smoothing_passes passes of 0.25/0.5/0.25 are one binomial kernel.
  smoothing_kernel_.assign(1, 1.0f);
  for (int pass = 0; pass < params_.smoothing_passes; ++pass) {
    std::vector<float> wider(smoothing_kernel_.size() + 2, 0.0f);
    for (std::size_t j = 0; j < smoothing_kernel_.size(); ++j) {
      wider[j] += 0.25f * smoothing_kernel_[j];
      wider[j + 1] += 0.5f * smoothing_kernel_[j];
      wider[j + 2] += 0.25f * smoothing_kernel_[j];
    }
    smoothing_kernel_.swap(wider);
  }
  pad_ = params_.smoothing_passes + params_.tangent_half_span;
}

void LineDetector::buildJacobians() {
  // The floor's Jacobian at every cell corner, by central differences half a cell each way
  // (one-sided where one side has no floor).
  jacobian_columns_ = floor_.width() / cell_size_ + 1;
  jacobian_rows_ = floor_.height() / cell_size_ + 1;
  jacobians_.assign(static_cast<std::size_t>(jacobian_columns_) * jacobian_rows_,
                    Jacobian{kNaN, kNaN, kNaN, kNaN, kNaN});
  const float h = 0.5f * static_cast<float>(cell_size_);
  for (int j = 0; j < jacobian_rows_; ++j) {
    for (int i = 0; i < jacobian_columns_; ++i) {
      const float u = static_cast<float>(i * cell_size_) + kCornerToPixel;
      const float v = static_cast<float>(j * cell_size_) + kCornerToPixel;
      // d(floor)/d(image) along one image axis from the points at -h, 0, +h.
      auto derivative = [&](float du, float dv, float& dx, float& dy) {
        float x0, y0, x1, y1;
        const bool before = floor_.floorPoint(u - du, v - dv, x0, y0);
        const bool after = floor_.floorPoint(u + du, v + dv, x1, y1);
        if (before && after) {
          dx = (x1 - x0) / (2 * h);
          dy = (y1 - y0) / (2 * h);
          return true;
        }
        float xc, yc;
        if (!floor_.floorPoint(u, v, xc, yc)) return false;
        if (after) {
          dx = (x1 - xc) / h;
          dy = (y1 - yc) / h;
          return true;
        }
        if (before) {
          dx = (xc - x0) / h;
          dy = (yc - y0) / h;
          return true;
        }
        return false;
      };
      Jacobian jac;
      float x, y;
      if (derivative(h, 0.0f, jac.xu, jac.yu) && derivative(0.0f, h, jac.xv, jac.yv) &&
          floor_.floorPoint(u, v, x, y)) {
        jac.range2 = x * x + y * y;
        jacobians_[static_cast<std::size_t>(j) * jacobian_columns_ + i] = jac;
      }
    }
  }
}

}  // namespace fieldline::region_tracking
