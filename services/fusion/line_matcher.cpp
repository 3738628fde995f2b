#include "services/fusion/line_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <queue>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "services/fusion/line_grid.hpp"

namespace fieldline::fusion {
namespace {

// A usable line point in the robot frame.
struct RobotPoint {
  double x;
  double y;
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

// Finite points within range; the rest are skipped.
void usablePoints(std::span<const perception::LinePoint> points, double max_range,
                  std::vector<RobotPoint>& out) {
  out.clear();
  out.reserve(points.size());
  const double max_squared = max_range * max_range;
  for (const perception::LinePoint& q : points) {
    const double x = q.x, y = q.y;
    if (!(std::isfinite(x) && std::isfinite(y))) continue;
    if (x * x + y * y > max_squared) continue;
    out.push_back({x, y});
  }
}

}  // namespace

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
  p.min_inliers = n.getOr<int>("min_inliers", p.min_inliers, 3, 100000);
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
    const bool cauchy = params.loss == RobustLoss::kCauchy;
    const double inverse_scale_squared = 1.0 / (params.loss_scale_m * params.loss_scale_m);
    double cauchy_product = 1.0, cauchy_logs = 0.0;
    int in_product = 0;
    for (const RobotPoint& q : points) {
      // The point's offset from the robot in the field frame, and its field position.
      const double ox = c * q.x - s * q.y;
      const double oy = s * q.x + c * q.y;
      double d, gx, gy;
      if (!grid.distanceGradient(pose.x + ox, pose.y + oy, d, gx, gy) || d > outlier) {
        cost += outlier_rho;
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
        w = weight(d);
        cost += rho(d);
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

  PoseCorrection correct(const std::vector<RobotPoint>& points, const geometry::Pose2& guess,
                         std::int64_t utime) const {
    PoseCorrection out;
    out.utime = utime;
    out.pose = guess;
    out.points_used = static_cast<int>(points.size());
    if (!geometry::isFinite(guess)) {
      out.cost = params.outlier_distance_m;
      return out;
    }
    Linearization at;
    geometry::Pose2 pose;
    if (params.method == MatchMethod::kForceField) {
      pose = forceField(points, guess, out.iterations);
      at = linearize(points, pose);
    } else {
      pose = leastSquares(points, guess, out.iterations, at);
    }
    pose.phi = geometry::normalizeAngle(pose.phi);
    out.pose = pose;
    out.inliers = at.inliers;
    out.cost = points.empty() ? params.outlier_distance_m
                              : at.seed_sum / static_cast<double>(points.size());

    // Covariance from the Hessian of the same fit at the answer, for both methods: sigma^2 (J^T W
    // J)^-1 with a weak prior in the directions the points do not constrain.
    const double point_variance = params.point_sigma_m * params.point_sigma_m;
    Eigen::Matrix3d information = at.information / point_variance;
    information(0, 0) += 1.0 / (params.unobservable_sigma_m * params.unobservable_sigma_m);
    information(1, 1) += 1.0 / (params.unobservable_sigma_m * params.unobservable_sigma_m);
    information(2, 2) += 1.0 / (params.unobservable_sigma_rad * params.unobservable_sigma_rad);
    out.covariance = information.inverse();
    out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
    const bool positive = out.covariance.allFinite() &&
                          Eigen::LLT<Eigen::Matrix3d>(out.covariance).info() == Eigen::Success;
    out.valid = positive && geometry::isFinite(pose) && out.inliers >= params.min_inliers;
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
  usablePoints(points, impl_->params.max_point_range_m, usable);
  return impl_->correct(usable, guess, utime);
}

double LineMatcher::cost(std::span<const perception::LinePoint> points,
                         const geometry::Pose2& pose) const {
  std::vector<RobotPoint> usable;
  usablePoints(points, impl_->params.max_point_range_m, usable);
  if (!geometry::isFinite(pose)) return impl_->params.outlier_distance_m;
  return impl_->seedCost(usable, pose, nullptr);
}

std::vector<PoseCorrection> LineMatcher::globalSearch(std::span<const perception::LinePoint> points,
                                                      const GlobalSearchParams& search,
                                                      std::int64_t utime) const {
  const Impl& m = *impl_;
  if (!(std::isfinite(search.position_step_m) && search.position_step_m >= 0.05 &&
        std::isfinite(search.heading_step_rad) && search.heading_step_rad >= 0.005 &&
        search.scoring_points >= 3 && search.refined >= 1 && search.max_results >= 1)) {
    throw std::invalid_argument("GlobalSearchParams: steps too small or counts below one");
  }
  std::vector<RobotPoint> usable;
  usablePoints(points, m.params.max_point_range_m, usable);
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
    PoseCorrection c = m.correct(usable, best.top().second, utime);
    best.pop();
    if (c.valid) refined.push_back(c);
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
  return distinct;
}

}  // namespace fieldline::fusion
