// Mirror calibration from rings, stage 4: the joint fit of the mirror centre, the axis offset and
// the ring radii (Levenberg-Marquardt with a Huber loss).
#include "tools/mirror_calibrate/mirror_calibration.hpp"

#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "common/geometry/fitting.hpp"
#include "tools/mirror_calibrate/numbers.hpp"

namespace fieldline::calibration {

// --- stage 4: the joint fit ---

double axisBearing(const Vec2& pixel, const Vec2& centre, double heading_angle, bool mirrored) {
  const Vec2 d = pixel - centre;
  return geometry::normalizeAngle((mirrored ? 1.0 : -1.0) *
                                  (std::atan2(d.y(), d.x()) - heading_angle));
}

double axisDistanceToRing(double distance, double bearing, const Vec2& offset) {
  const double ou = offset.x() * std::cos(bearing) + offset.y() * std::sin(bearing);
  const double disc = ou * ou - offset.squaredNorm() + distance * distance;
  if (disc < 0.0) return kNaN;
  const double t = -ou + std::sqrt(disc);
  return t > 0.0 ? t : kNaN;
}

double RingFit::radiusAt(double distance) const {
  std::vector<double> x{0.0};
  std::vector<double> y{0.0};
  x.insert(x.end(), distances.begin(), distances.end());
  y.insert(y.end(), radii.begin(), radii.end());
  return MonotoneCurve(x, y)(distance);
}

double RingFit::ringRadius(int ring, double bearing) const {
  return radiusAt(
      axisDistanceToRing(distances[static_cast<std::size_t>(ring)], bearing, axis_offset));
}

Eigen::VectorXd levenbergMarquardt(Eigen::VectorXd x, const ResidualFunction& f,
                                   const std::vector<double>& steps, double huber, int iterations) {
  const Eigen::Index np = x.size();
  double lambda = 1e-3;
  Eigen::VectorXd r;
  if (!f(x, r)) throw std::invalid_argument("mirror fit: the start guess is not a valid mirror");
  auto cost = [huber](const Eigen::VectorXd& res) {
    double c = 0.0;
    for (Eigen::Index i = 0; i < res.size(); ++i) {
      const double a = std::abs(res(i));
      c += a <= huber ? 0.5 * a * a : huber * (a - 0.5 * huber);
    }
    return c;
  };
  double current = cost(r);
  for (int it = 0; it < iterations; ++it) {
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(r.size(), np);
    for (Eigen::Index k = 0; k < np; ++k) {
      const double h = steps[static_cast<std::size_t>(k)];
      if (h == 0.0) continue;
      Eigen::VectorXd xp = x;
      xp(k) += h;
      Eigen::VectorXd rp;
      if (f(xp, rp)) {
        j.col(k) = (rp - r) / h;
      } else {
        xp(k) -= 2 * h;
        if (f(xp, rp)) j.col(k) = (r - rp) / h;
      }
    }
    Eigen::VectorXd w(r.size());
    for (Eigen::Index i = 0; i < r.size(); ++i) {
      const double a = std::abs(r(i));
      w(i) = a <= huber ? 1.0 : huber / a;
    }
    const Eigen::MatrixXd jtw = j.transpose() * w.asDiagonal();
    Eigen::MatrixXd a = jtw * j;
    const Eigen::VectorXd g = jtw * r;
    for (Eigen::Index k = 0; k < np; ++k) {
      if (a(k, k) <= 0.0) a(k, k) = 1.0;  // a parameter held fixed or without data
    }
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::MatrixXd damped = a;
      for (Eigen::Index k = 0; k < np; ++k)
        damped(k, k) *= 1.0 + lambda;
      const Eigen::VectorXd step = damped.ldlt().solve(-g);
      const Eigen::VectorXd xn = x + step;
      Eigen::VectorXd rn;
      if (step.allFinite() && f(xn, rn) && cost(rn) < current) {
        const bool tiny = step.norm() < 1e-7;
        x = xn;
        r = rn;
        current = cost(rn);
        lambda = std::max(1e-7, lambda * 0.3);
        improved = true;
        if (tiny) return x;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return x;
}

namespace {

struct FitState {
  Vec2 centre;
  Vec2 offset;
  std::vector<double> radii;
};

bool increasing(const std::vector<double>& v) {
  if (v.empty() || !(v[0] > 0.0)) return false;
  for (std::size_t i = 1; i < v.size(); ++i)
    if (!(v[i] > v[i - 1])) return false;
  return true;
}

// Residuals r_obs - r_pred of the points (NaN-free only if the state is valid).
bool residuals(const FitState& s, const std::vector<RingPoint>& pts,
               const std::vector<double>& distances, const camera::MirrorParams& base,
               const std::vector<bool>& use, Eigen::VectorXd& out) {
  if (!increasing(s.radii)) return false;
  std::vector<double> x{0.0};
  std::vector<double> y{0.0};
  x.insert(x.end(), distances.begin(), distances.end());
  y.insert(y.end(), s.radii.begin(), s.radii.end());
  const MonotoneCurve curve(x, y);
  out.resize(static_cast<Eigen::Index>(pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (!use[i]) {
      out(static_cast<Eigen::Index>(i)) = 0.0;
      continue;
    }
    const double b = axisBearing(pts[i].pixel, s.centre, base.heading_angle, base.mirrored);
    const double t =
        axisDistanceToRing(distances[static_cast<std::size_t>(pts[i].ring)], b, s.offset);
    if (!std::isfinite(t)) return false;
    out(static_cast<Eigen::Index>(i)) = (pts[i].pixel - s.centre).norm() - curve(t);
  }
  return true;
}

FitState unpack(const Eigen::VectorXd& x, bool offset) {
  FitState s;
  s.centre = Vec2(x(0), x(1));
  s.offset = offset ? Vec2(x(2), x(3)) : Vec2::Zero();
  for (Eigen::Index i = 4; i < x.size(); ++i)
    s.radii.push_back(x(i));
  return s;
}

using ResidualFn = ResidualFunction;

Eigen::VectorXd solve(const Eigen::VectorXd& x, const std::vector<RingPoint>& pts,
                      const std::vector<double>& distances, const camera::MirrorParams& base,
                      const std::vector<bool>& use, const RingFitParams& params) {
  std::vector<double> steps(static_cast<std::size_t>(x.size()), 1e-4);
  steps[2] = steps[3] = params.fit_offset ? 1e-5 : 0.0;
  const ResidualFn f = [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) {
    return residuals(unpack(v, params.fit_offset), pts, distances, base, use, out);
  };
  return levenbergMarquardt(x, f, steps, params.huber_px, params.iterations);
}

}  // namespace

RingFit fitRings(const std::vector<RingPoint>& points, const std::vector<double>& distances,
                 const camera::MirrorParams& base, const Vec2& start_centre,
                 const std::vector<double>& start_radii, const RingFitParams& params) {
  if (start_radii.size() != distances.size() || !increasing(start_radii) ||
      !increasing(distances)) {
    throw std::invalid_argument("mirror fit: one increasing start radius per increasing distance");
  }
  for (const RingPoint& p : points) {
    if (p.ring < 0 || p.ring >= static_cast<int>(distances.size())) {
      throw std::invalid_argument("mirror fit: a point names a ring that has no distance");
    }
  }
  const auto np = static_cast<Eigen::Index>(4 + distances.size());
  Eigen::VectorXd x(np);
  x << start_centre.x(), start_centre.y(), 0.0, 0.0,
      Eigen::Map<const Eigen::VectorXd>(start_radii.data(),
                                        static_cast<Eigen::Index>(start_radii.size()));
  std::vector<bool> use(points.size(), true);
  x = solve(x, points, distances, base, use, params);
  // Drop the outliers of the first fit and fit again.
  Eigen::VectorXd r;
  residuals(unpack(x, params.fit_offset), points, distances, base, use, r);
  std::vector<double> abs;
  for (Eigen::Index i = 0; i < r.size(); ++i)
    abs.push_back(std::abs(r(i)));
  const double sigma = 1.4826 * geometry::median(abs);
  const double gate = std::max(params.outlier_px, 4.0 * sigma);
  for (std::size_t i = 0; i < use.size(); ++i)
    use[i] = abs[i] <= gate;
  x = solve(x, points, distances, base, use, params);

  RingFit fit;
  const FitState s = unpack(x, params.fit_offset);
  fit.centre = s.centre;
  fit.axis_offset = s.offset;
  fit.distances = distances;
  fit.radii = s.radii;
  fit.inlier = use;
  if (!residuals(s, points, distances, base, use, r)) {
    throw std::invalid_argument("mirror fit: the fit did not keep the ring radii increasing");
  }
  double sum = 0.0;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (use[i]) {
      ++fit.inliers;
      sum += r(static_cast<Eigen::Index>(i)) * r(static_cast<Eigen::Index>(i));
    } else {
      ++fit.outliers;
    }
  }
  fit.rms_px = fit.inliers > 0 ? std::sqrt(sum / fit.inliers) : kNaN;
  return fit;
}

}  // namespace fieldline::calibration
