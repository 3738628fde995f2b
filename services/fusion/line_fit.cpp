// Layer 2's robust fit of the line points to the field's lines (line_matcher.hpp): the normal
// equations, Levenberg-Marquardt, the seed's force field and matching distance.
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

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace fieldline::fusion {

// long: layer 2's hot loop (most of fusion's CPU): the SSE2 pairs, the scalar tail and the running
// sums they share stay in one function so the sums live in registers.
LineMatcher::Impl::Linearization LineMatcher::Impl::linearize(const std::vector<RobotPoint>& points,
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
  // One point's share, in the points' order: `on` when it lies on the grid, its offset (ox, oy)
  // from the robot in the field frame, its distance d and the distance's gradient (gx, gy).
  // Always inlined: called out of line (GCC -O2 did) the sums it adds to live in memory.
  const auto add = [&](const RobotPoint& q, bool on, double ox, double oy, double d, double gx,
                       double gy) __attribute__((always_inline)) {
    if (!on || d > outlier) {
      cost += q.w * outlier_rho;
      seed_sum += outlier;
      return;
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
  };
  const std::size_t n = points.size();
  std::size_t k = 0;
#if defined(__SSE2__)
  // Two points at a time: their offsets and the grid's interpolation in the two lanes of SSE2
  // registers (the same operations as the scalar code, lane by lane, so the same bits), then
  // their shares added one after the other as below.
  const __m128d vc = _mm_set1_pd(c), vs = _mm_set1_pd(s);
  const __m128d vx = _mm_set1_pd(pose.x), vy = _mm_set1_pd(pose.y);
  alignas(16) double ox[2], oy[2], d[2], gx[2], gy[2];
  for (; k + 2 <= n; k += 2) {
    if (k + kPrefetchAhead < n) prefetchAt(points[k + kPrefetchAhead], pose, c, s);
    if (k + kPrefetchAhead + 1 < n) prefetchAt(points[k + kPrefetchAhead + 1], pose, c, s);
    const __m128d qx = _mm_set_pd(points[k + 1].x, points[k].x);
    const __m128d qy = _mm_set_pd(points[k + 1].y, points[k].y);
    const __m128d vox = _mm_sub_pd(_mm_mul_pd(vc, qx), _mm_mul_pd(vs, qy));
    const __m128d voy = _mm_add_pd(_mm_mul_pd(vs, qx), _mm_mul_pd(vc, qy));
    __m128d vd, vgx, vgy;
    const int on = grid.distanceGradient2(_mm_add_pd(vx, vox), _mm_add_pd(vy, voy), vd, vgx, vgy);
    _mm_store_pd(ox, vox);
    _mm_store_pd(oy, voy);
    _mm_store_pd(d, vd);
    _mm_store_pd(gx, vgx);
    _mm_store_pd(gy, vgy);
    add(points[k], (on & 1) != 0, ox[0], oy[0], d[0], gx[0], gy[0]);
    add(points[k + 1], (on & 2) != 0, ox[1], oy[1], d[1], gx[1], gy[1]);
  }
#endif
  for (; k < n; ++k) {
    const RobotPoint& q = points[k];
    if (k + kPrefetchAhead < n) prefetchAt(points[k + kPrefetchAhead], pose, c, s);
    // The point's offset from the robot in the field frame, and its field position.
    const double ox = c * q.x - s * q.y;
    const double oy = s * q.x + c * q.y;
    double d = 0.0, gx = 0.0, gy = 0.0;
    const bool on = grid.distanceGradient(pose.x + ox, pose.y + oy, d, gx, gy);
    add(q, on, ox, oy, d, gx, gy);
  }
  out.information << h00, h01, h02, h01, h11, h12, h02, h12, h22;
  out.gradient << b0, b1, b2;
  if (cauchy) {
    cost +=
        0.5 * params.loss_scale_m * params.loss_scale_m * (cauchy_logs + std::log(cauchy_product));
  }
  out.robust_cost = cost;
  out.seed_sum = seed_sum;
  out.inliers = inliers;
  return out;
}

geometry::Pose2 LineMatcher::Impl::leastSquares(const std::vector<RobotPoint>& points,
                                                geometry::Pose2 pose, int& iterations,
                                                Linearization& current) const {
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

geometry::Pose2 LineMatcher::Impl::forceField(const std::vector<RobotPoint>& points,
                                              geometry::Pose2 pose, int& iterations) const {
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

double LineMatcher::Impl::seedCost(const std::vector<RobotPoint>& points,
                                   const geometry::Pose2& pose, int* inliers) const {
  const double outlier = params.outlier_distance_m;
  if (points.empty()) return outlier;
  const double c = std::cos(pose.phi), s = std::sin(pose.phi);
  double sum = 0.0;
  int count = 0;
  for (const RobotPoint& q : points) {
    double d;
    if (grid.distance(pose.x + c * q.x - s * q.y, pose.y + s * q.x + c * q.y, d) && d <= outlier) {
      sum += d;
      ++count;
    } else {
      sum += outlier;
    }
  }
  if (inliers) *inliers = count;
  return sum / static_cast<double>(points.size());
}

}  // namespace fieldline::fusion
