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
#include "services/fusion/line_matcher_impl.hpp"

namespace fieldline::fusion {
namespace {

LineGridSettings gridSettings(const MatcherParams& p) {
  return LineGridSettings{p.grid_cell_m, p.grid_margin_m, p.force_decay_per_m, p.force_cap_m};
}

}  // namespace

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

LineMatcher::LineMatcher(const field::FieldModel& field, MatcherParams params,
                         const std::string& cache_dir)
    : impl_(std::make_unique<Impl>()) {
  validateMatcherParams(params);
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

std::vector<geometry::Pose2> LineMatcher::Impl::bestLatticePoses(
    const std::vector<RobotPoint>& usable, const GlobalSearchParams& search) const {
  // Score the lattice with an even subsample: the seed's cost, outliers at the outlier distance.
  std::vector<RobotPoint> scoring;
  const std::size_t stride =
      std::max<std::size_t>(1, usable.size() / static_cast<std::size_t>(search.scoring_points));
  for (std::size_t k = 0; k < usable.size(); k += stride)
    scoring.push_back(usable[k]);
  const int headings =
      std::max(1, static_cast<int>(std::ceil(2.0 * std::numbers::pi / search.heading_step_rad)));
  const int columns = static_cast<int>(2.0 * carpet_half.x() / search.position_step_m) + 1;
  const int rows = static_cast<int>(2.0 * carpet_half.y() / search.position_step_m) + 1;
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
          sum += coarseDistance(x + q.x, y + q.y);
          if (sum >= bound) break;  // cannot enter the kept set any more
        }
        if (sum >= bound) continue;
        best.push({sum, geometry::Pose2{x, y, phi}});
        if (best.size() > static_cast<std::size_t>(search.refined)) best.pop();
      }
    }
  }
  std::vector<geometry::Pose2> poses;
  for (; !best.empty(); best.pop())
    poses.push_back(best.top().second);
  return poses;
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

  std::vector<geometry::Pose2> lattice = m.bestLatticePoses(usable, search);
  std::vector<PoseCorrection> refined;
  for (const geometry::Pose2& pose : lattice) {
    PoseCorrection c = m.correct(usable, pose, utime, false);
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
