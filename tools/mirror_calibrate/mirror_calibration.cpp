#include "tools/mirror_calibrate/mirror_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <fmt/core.h>
#include <Eigen/Dense>

namespace fieldline::calibration {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = std::numbers::pi;

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Kasa circle fit: centre and radius of the circle closest (algebraically) to the points.
bool fitCircle(const std::vector<Vec2>& pts, Vec2& centre, double& radius) {
  if (pts.size() < 5) return false;
  Eigen::MatrixXd a(pts.size(), 3);
  Eigen::VectorXd b(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    a(static_cast<Eigen::Index>(i), 0) = pts[i].x();
    a(static_cast<Eigen::Index>(i), 1) = pts[i].y();
    a(static_cast<Eigen::Index>(i), 2) = 1.0;
    b(static_cast<Eigen::Index>(i)) = pts[i].squaredNorm();
  }
  const Eigen::Vector3d s = a.colPivHouseholderQr().solve(b);
  centre = Vec2(s(0) / 2, s(1) / 2);
  const double r2 = s(2) + centre.squaredNorm();
  if (!(r2 > 0.0) || !centre.allFinite()) return false;
  radius = std::sqrt(r2);
  return true;
}

// Image radius along image direction `dir` from `from` to the circle (centre, radius).
double circleAlongRay(const Vec2& from, const Vec2& dir, const Vec2& centre, double radius) {
  const Vec2 f = from - centre;
  const double b = f.dot(dir);
  const double disc = b * b - (f.squaredNorm() - radius * radius);
  return disc < 0.0 ? kNaN : -b + std::sqrt(disc);
}

double wrapAngle(double a) {
  return std::remainder(a, 2.0 * kPi);
}

}  // namespace

bool fitCircleRobust(const std::vector<Vec2>& pts, Vec2& centre, double& radius,
                     std::vector<bool>& keep, double gate) {
  keep.assign(pts.size(), true);
  std::vector<Vec2> used = pts;
  for (int round = 0; round < 3; ++round) {
    if (!fitCircle(used, centre, radius)) return false;
    std::vector<double> res;
    for (const Vec2& p : pts)
      res.push_back(std::abs((p - centre).norm() - radius));
    const double g = round == 0 ? std::max(gate, 3.0 * median(res)) : gate;
    used.clear();
    for (std::size_t i = 0; i < pts.size(); ++i) {
      keep[i] = res[i] <= g;
      if (keep[i]) used.push_back(pts[i]);
    }
  }
  return fitCircle(used, centre, radius);
}

// --- images and curves ---

MonotoneCurve::MonotoneCurve(std::vector<double> x, std::vector<double> y)
    : x_(std::move(x)), y_(std::move(y)) {
  const std::size_t n = x_.size();
  if (n < 2 || y_.size() != n) throw std::invalid_argument("monotone curve: two knots needed");
  std::vector<double> secant(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double dx = x_[i + 1] - x_[i];
    if (!(dx > 0.0) || !(y_[i + 1] >= y_[i])) {
      throw std::invalid_argument("monotone curve: x must increase and y must not decrease");
    }
    secant[i] = (y_[i + 1] - y_[i]) / dx;
  }
  // Slopes of the parabola through each knot and its neighbours (second-order accurate on a
  // smooth curve), limited so that the cubic stays monotone (Hyman's filter: zero at a flat
  // secant, at most three times the smaller neighbouring secant).
  slope_.assign(n, 0.0);
  if (n == 2) {
    slope_[0] = slope_[1] = secant[0];
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    double m = 0.0;
    double limit = 0.0;
    if (i == 0) {
      const double h0 = x_[1] - x_[0];
      const double h1 = x_[2] - x_[1];
      m = ((2 * h0 + h1) * secant[0] - h0 * secant[1]) / (h0 + h1);
      limit = 3.0 * secant[0];
    } else if (i == n - 1) {
      const double h0 = x_[n - 2] - x_[n - 3];
      const double h1 = x_[n - 1] - x_[n - 2];
      m = ((2 * h1 + h0) * secant[n - 2] - h1 * secant[n - 3]) / (h0 + h1);
      limit = 3.0 * secant[n - 2];
    } else {
      const double h0 = x_[i] - x_[i - 1];
      const double h1 = x_[i + 1] - x_[i];
      m = (h1 * secant[i - 1] + h0 * secant[i]) / (h0 + h1);
      limit = 3.0 * std::min(secant[i - 1], secant[i]);
    }
    slope_[i] = std::clamp(m, 0.0, std::max(0.0, limit));
  }
}

double MonotoneCurve::operator()(double x) const {
  const std::size_t n = x_.size();
  if (!std::isfinite(x)) return kNaN;
  if (x <= x_[0]) return y_[0] + slope_[0] * (x - x_[0]);
  if (x >= x_[n - 1]) return y_[n - 1] + slope_[n - 1] * (x - x_[n - 1]);
  const std::size_t i =
      static_cast<std::size_t>(std::upper_bound(x_.begin(), x_.end(), x) - x_.begin()) - 1;
  const double h = x_[i + 1] - x_[i];
  const double t = (x - x_[i]) / h;
  const double t2 = t * t;
  const double t3 = t2 * t;
  return (2 * t3 - 3 * t2 + 1) * y_[i] + (t3 - 2 * t2 + t) * h * slope_[i] +
         (-2 * t3 + 3 * t2) * y_[i + 1] + (t3 - t2) * h * slope_[i + 1];
}

// --- stage 1: ridges along rays ---

std::vector<RingPeak> findRingPeaks(const GreyImage& image, const Vec2& centre,
                                    const RingSearchParams& params) {
  if (params.rays < 8 || !(params.step > 0.0) || !(params.window > params.step) ||
      !(params.max_radius > params.min_radius) || params.min_radius < 0.0) {
    throw std::invalid_argument("ring search: bad parameters");
  }
  std::vector<RingPeak> peaks;
  const int w = static_cast<int>(std::lround(params.window / params.step));
  const double r0 = std::max(0.0, params.min_radius - params.window);
  const int n = static_cast<int>((params.max_radius + params.window - r0) / params.step) + 1;
  std::vector<double> raw(static_cast<std::size_t>(n));
  std::vector<double> p(static_cast<std::size_t>(n));
  for (int ray = 0; ray < params.rays; ++ray) {
    const double a = 2.0 * kPi * ray / params.rays;
    const Vec2 dir(std::cos(a), std::sin(a));
    int len = 0;
    for (; len < n; ++len) {
      const Vec2 q = centre + (r0 + len * params.step) * dir;
      const double s = image.sample(q.x(), q.y());
      if (!std::isfinite(s)) break;
      raw[static_cast<std::size_t>(len)] = s;
    }
    // Light smoothing (binomial over one pixel) against sensor noise.
    for (int i = 0; i < len; ++i) {
      const auto at = [&](int k) {
        return raw[static_cast<std::size_t>(std::clamp(k, 0, len - 1))];
      };
      p[static_cast<std::size_t>(i)] =
          (at(i - 2) + 4 * at(i - 1) + 6 * at(i) + 4 * at(i + 1) + at(i + 2)) / 16.0;
    }
    int lastEnd = -1;
    for (int i = w; i + w < len; ++i) {
      const double r = r0 + i * params.step;
      if (r < params.min_radius || r > params.max_radius) continue;
      const double v = p[static_cast<std::size_t>(i)];
      // A local maximum (the first sample of a plateau).
      if (!(v > p[static_cast<std::size_t>(i - 1)])) continue;
      int j = i;
      while (j + 1 < len && p[static_cast<std::size_t>(j + 1)] == v)
        ++j;
      if (j + 1 >= len || !(p[static_cast<std::size_t>(j + 1)] < v)) continue;
      const int mid = (i + j) / 2;
      double left = std::numeric_limits<double>::infinity();
      double right = left;
      for (int k = mid - w; k < mid; ++k)
        left = std::min(left, p[static_cast<std::size_t>(std::max(k, 0))]);
      for (int k = mid + 1; k <= mid + w; ++k)
        right = std::min(right, p[static_cast<std::size_t>(std::min(k, len - 1))]);
      const double base = std::max(left, right);
      const double contrast = v - base;
      if (contrast < params.min_contrast) continue;
      // The ridge: samples above half height around the maximum; its brightness-weighted centre.
      const double half = base + 0.5 * contrast;
      int lo = i;
      int hi = j;
      while (lo - 1 >= 0 && p[static_cast<std::size_t>(lo - 1)] > half)
        --lo;
      while (hi + 1 < len && p[static_cast<std::size_t>(hi + 1)] > half)
        ++hi;
      if (lo <= lastEnd) continue;  // the same ridge as the previous maximum
      lastEnd = hi;
      double sw = 0.0;
      double sr = 0.0;
      for (int k = lo; k <= hi; ++k) {
        const double wk = p[static_cast<std::size_t>(k)] - half;
        sw += wk;
        sr += wk * (r0 + k * params.step);
      }
      const double radius = sw > 0.0 ? sr / sw : r;
      peaks.push_back({ray, radius, contrast, centre + radius * dir});
      i = j;
    }
  }
  return peaks;
}

// --- stage 2: rings, traced outward ---

std::vector<TracedRing> traceRings(const std::vector<RingPeak>& peaks, int rays, const Vec2& centre,
                                   double min_share, double gap) {
  std::vector<std::vector<const RingPeak*>> byRay(static_cast<std::size_t>(rays));
  for (const RingPeak& p : peaks) {
    if (p.ray >= 0 && p.ray < rays) byRay[static_cast<std::size_t>(p.ray)].push_back(&p);
  }
  for (auto& list : byRay) {
    std::sort(list.begin(), list.end(),
              [](const RingPeak* a, const RingPeak* b) { return a->radius < b->radius; });
  }
  std::vector<TracedRing> rings;
  // Per ray: the radius beyond which the next ring is looked for.
  std::vector<double> floorRadius(static_cast<std::size_t>(rays), 0.0);
  for (int guard = 0; guard < 64; ++guard) {
    std::vector<Vec2> pts;
    std::vector<int> rayOf;
    for (int ray = 0; ray < rays; ++ray) {
      for (const RingPeak* p : byRay[static_cast<std::size_t>(ray)]) {
        if (p->radius > floorRadius[static_cast<std::size_t>(ray)]) {
          pts.push_back(p->pixel);
          rayOf.push_back(ray);
          break;
        }
      }
    }
    if (static_cast<double>(pts.size()) < min_share * rays) break;
    TracedRing ring;
    std::vector<bool> keep;
    if (!fitCircleRobust(pts, ring.centre, ring.radius, keep, 2.0)) break;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      if (keep[i]) ring.pixels.push_back(pts[i]);
    }
    if (static_cast<double>(ring.pixels.size()) < min_share * rays) break;
    rings.push_back(ring);
    // Next ring: beyond this one's circle (or its point on the ray) plus the gap.
    for (int ray = 0; ray < rays; ++ray) {
      const double a = 2.0 * kPi * ray / rays;
      const double onCircle =
          circleAlongRay(centre, Vec2(std::cos(a), std::sin(a)), ring.centre, ring.radius);
      floorRadius[static_cast<std::size_t>(ray)] =
          std::max(floorRadius[static_cast<std::size_t>(ray)],
                   std::isfinite(onCircle) ? onCircle + gap : 1e9);
    }
  }
  return rings;
}

// --- stage 3: which ring is which distance ---

namespace {

// RMS relative misfit of d = a r + b r^2 + c r^3 through the pairs.
double cubicMisfit(const std::vector<double>& r, const std::vector<double>& d) {
  const auto n = static_cast<Eigen::Index>(r.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = r[static_cast<std::size_t>(i)];
    const double y = d[static_cast<std::size_t>(i)];
    // Weighted by 1/d: relative misfit.
    a(i, 0) = x / y;
    a(i, 1) = x * x / y;
    a(i, 2) = x * x * x / y;
    b(i) = 1.0;
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(b);
  return std::sqrt((a * c - b).squaredNorm() / static_cast<double>(n));
}

}  // namespace

RingMatch matchRings(const std::vector<double>& radii, const std::vector<double>& distances) {
  const int k = static_cast<int>(radii.size());
  const int m = static_cast<int>(distances.size());
  const int count = std::min(k, m);
  if (count < 4) {
    throw std::invalid_argument(fmt::format(
        "ring matching: {} rings found and {} distances given; at least 4 of each are needed", k,
        m));
  }
  RingMatch best;
  best.misfit = std::numeric_limits<double>::infinity();
  // Slide the shorter list along the longer one.
  for (int shift = 0; shift <= std::abs(k - m); ++shift) {
    const int fr = k > m ? shift : 0;
    const int fd = k > m ? 0 : shift;
    std::vector<double> r(radii.begin() + fr, radii.begin() + fr + count);
    std::vector<double> d(distances.begin() + fd, distances.begin() + fd + count);
    const double misfit = cubicMisfit(r, d);
    if (misfit < best.misfit) best = {fr, fd, count, misfit};
  }
  return best;
}

// --- stage 4: the joint fit ---

double axisBearing(const Vec2& pixel, const Vec2& centre, double heading_angle, bool mirrored) {
  const Vec2 d = pixel - centre;
  return wrapAngle((mirrored ? 1.0 : -1.0) * (std::atan2(d.y(), d.x()) - heading_angle));
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
  const double sigma = 1.4826 * median(abs);
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

// --- stage 5: the table per sector ---

SectorTable sectorTable(const RingFit& fit, const std::vector<RingPoint>& points,
                        const camera::MirrorParams& base, int sectors, double radius_step) {
  if (sectors < 1 || sectors > 360 || !(radius_step > 0.0)) {
    throw std::invalid_argument("sector table: sectors in 1..360 and radius_step > 0 expected");
  }
  const std::size_t nr = fit.distances.size();
  const double width = 2.0 * kPi / sectors;
  std::vector<double> bearings;
  for (int s = 0; s < sectors; ++s)
    bearings.push_back(sectors == 1 ? 0.0 : -kPi + width * (s + 1));
  auto sectorOf = [&](double b) {
    if (sectors == 1) return 0;
    int best = 0;
    for (int s = 1; s < sectors; ++s) {
      if (std::abs(wrapAngle(b - bearings[static_cast<std::size_t>(s)])) <
          std::abs(wrapAngle(b - bearings[static_cast<std::size_t>(best)]))) {
        best = s;
      }
    }
    return best;
  };
  // Per sector and ring: radii moved to the sector's bearing with the global fit.
  std::vector<std::vector<std::vector<double>>> moved(static_cast<std::size_t>(sectors),
                                                      std::vector<std::vector<double>>(nr));
  std::vector<double> bearingOfPoint(points.size(), 0.0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double b = axisBearing(points[i].pixel, fit.centre, base.heading_angle, base.mirrored);
    bearingOfPoint[i] = b;
    if (!fit.inlier.empty() && !fit.inlier[i]) continue;
    const int s = sectorOf(b);
    const double here = fit.ringRadius(points[i].ring, b);
    const double there = fit.ringRadius(points[i].ring, bearings[static_cast<std::size_t>(s)]);
    moved[static_cast<std::size_t>(s)][static_cast<std::size_t>(points[i].ring)].push_back(
        (points[i].pixel - fit.centre).norm() + there - here);
  }
  std::vector<std::vector<double>> knotR(static_cast<std::size_t>(sectors));
  std::vector<std::vector<double>> knotD(static_cast<std::size_t>(sectors));
  double end = std::numeric_limits<double>::infinity();
  double farthest = 0.0;
  for (int s = 0; s < sectors; ++s) {
    const auto su = static_cast<std::size_t>(s);
    std::vector<double> r{0.0};
    std::vector<double> d{0.0};
    for (std::size_t k = 0; k < nr; ++k) {
      const double t = axisDistanceToRing(fit.distances[k], bearings[su], fit.axis_offset);
      double rk = moved[su][k].size() >= 3 ? median(moved[su][k]) : kNaN;
      // Too few points here (a strut, the image's edge): the global fit's radius.
      if (!std::isfinite(rk) || !(rk > r.back())) rk = fit.radiusAt(t);
      if (!(rk > r.back()) || !(t > d.back())) continue;
      r.push_back(rk);
      d.push_back(t);
    }
    if (r.size() < 3) throw std::invalid_argument("sector table: a sector has too few rings");
    end = std::min(end, r.back());
    farthest = std::max(farthest, r.back());
    knotR[su] = r;
    knotD[su] = d;
  }
  // Up to the outermost ring of any sector, extrapolating the others by at most 3 px.
  end = std::min(farthest, end + 3.0);
  SectorTable out;
  // Knots every radius_step, none within half a pixel of the last (the loader's check refuses
  // knots closer than that: at 640x480 the outermost ring fell 0.3 px beyond a step).
  for (double rad = radius_step; rad < end - 0.5; rad += radius_step)
    out.table.radii.push_back(rad);
  out.table.radii.push_back(end);
  for (int s = 0; s < sectors; ++s) {
    const auto su = static_cast<std::size_t>(s);
    const MonotoneCurve curve(knotR[su], knotD[su]);
    std::vector<double> d;
    for (double rad : out.table.radii)
      d.push_back(curve(rad));
    out.table.sector_bearings.push_back(bearings[su]);
    out.table.distances.push_back(d);
  }
  // Residuals of the finished table.
  const camera::DistanceFunction table{out.table};
  struct Acc {
    int n = 0;
    double px2 = 0, pc2 = 0, maxp = 0, maxcm = 0;
    std::vector<bool> rings;
  };
  std::vector<Acc> acc(static_cast<std::size_t>(sectors) + 1);
  for (Acc& a : acc)
    a.rings.assign(nr, false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!fit.inlier.empty() && !fit.inlier[i]) continue;
    const double b = bearingOfPoint[i];
    const double rad = (points[i].pixel - fit.centre).norm();
    const double t = axisDistanceToRing(fit.distances[static_cast<std::size_t>(points[i].ring)], b,
                                        fit.axis_offset);
    const double dist = table.floorDistance(rad, b);
    const double rr = table.imageRadius(t, b);
    if (!std::isfinite(dist) || !std::isfinite(rr)) continue;
    const double pc = 100.0 * std::abs(dist - t) / t;
    for (Acc* a : {&acc[static_cast<std::size_t>(sectorOf(b))], &acc.back()}) {
      ++a->n;
      a->px2 += (rad - rr) * (rad - rr);
      a->pc2 += pc * pc;
      a->maxp = std::max(a->maxp, pc);
      a->maxcm = std::max(a->maxcm, 100.0 * std::abs(dist - t));
      a->rings[static_cast<std::size_t>(points[i].ring)] = true;
    }
  }
  auto summary = [](const Acc& a, double bearing) {
    SectorResidual r;
    r.bearing = bearing;
    r.points = a.n;
    r.rings = static_cast<int>(std::count(a.rings.begin(), a.rings.end(), true));
    r.rms_px = a.n > 0 ? std::sqrt(a.px2 / a.n) : kNaN;
    r.rms_percent = a.n > 0 ? std::sqrt(a.pc2 / a.n) : kNaN;
    r.max_percent = a.maxp;
    r.max_cm = a.maxcm;
    return r;
  };
  for (int s = 0; s < sectors; ++s) {
    out.residuals.push_back(
        summary(acc[static_cast<std::size_t>(s)], bearings[static_cast<std::size_t>(s)]));
  }
  out.total = summary(acc.back(), 0.0);
  return out;
}

// --- stages 1-5 ---

RingCalibration calibrateFromRings(const GreyImage& image, const std::vector<double>& distances,
                                   const camera::MirrorParams& base,
                                   const RingCalibrationParams& params) {
  if (image.width != base.width || image.height != base.height) {
    throw std::invalid_argument(
        fmt::format("mirror calibration: the image is {}x{} but the camera config says {}x{}",
                    image.width, image.height, base.width, base.height));
  }
  RingCalibration out;
  const int rays = params.search.rays;
  const std::vector<RingPeak> first = findRingPeaks(image, base.centre, params.search);
  const std::vector<TracedRing> traced = traceRings(first, rays, base.centre, 0.3, 1.0);
  if (traced.size() < 4) {
    throw std::invalid_argument(fmt::format(
        "mirror calibration: {} rings found around ({:.1f}, {:.1f}) between {} and {} px (4 or "
        "more needed): check the centre guess, the radii searched and --min-contrast",
        traced.size(), base.centre.x(), base.centre.y(), params.search.min_radius,
        params.search.max_radius));
  }
  for (const TracedRing& t : traced)
    out.found_radii.push_back(t.radius);
  out.match = matchRings(out.found_radii, distances);
  out.distances.assign(distances.begin() + out.match.first_distance,
                       distances.begin() + out.match.first_distance + out.match.count);
  // First points: the traced rings' points; start: the outermost matched ring's centre (least
  // moved by an axis offset) and the traced radii.
  std::vector<double> radii;
  for (int k = 0; k < out.match.count; ++k) {
    const TracedRing& t = traced[static_cast<std::size_t>(out.match.first_ring + k)];
    radii.push_back(t.radius);
    for (const Vec2& p : t.pixels)
      out.points.push_back({p, k});
  }
  const Vec2 start =
      traced[static_cast<std::size_t>(out.match.first_ring + out.match.count - 1)].centre;
  out.fit = fitRings(out.points, out.distances, base, start, radii, params.fit);
  // Rounds: search again around the fitted centre; assign each peak to the predicted ring
  // nearest to it (within 0.4 of the gap to the neighbours); fit again.
  for (int round = 0; round < params.rounds; ++round) {
    const std::vector<RingPeak> peaks = findRingPeaks(image, out.fit.centre, params.search);
    std::vector<RingPoint> pts;
    const int n = out.match.count;
    for (const RingPeak& p : peaks) {
      const double b = axisBearing(p.pixel, out.fit.centre, base.heading_angle, base.mirrored);
      int best = -1;
      double bestDist = 1e9;
      double gate = 0.0;
      std::vector<double> pred(static_cast<std::size_t>(n));
      for (int k = 0; k < n; ++k)
        pred[static_cast<std::size_t>(k)] = out.fit.ringRadius(k, b);
      for (int k = 0; k < n; ++k) {
        const double dk = std::abs(p.radius - pred[static_cast<std::size_t>(k)]);
        if (dk < bestDist) {
          bestDist = dk;
          best = k;
          const double lo =
              k > 0 ? pred[static_cast<std::size_t>(k)] - pred[static_cast<std::size_t>(k - 1)]
                    : 1e9;
          const double hi =
              k + 1 < n ? pred[static_cast<std::size_t>(k + 1)] - pred[static_cast<std::size_t>(k)]
                        : 1e9;
          gate = 0.4 * std::min({lo, hi, 10.0});
        }
      }
      if (best >= 0 && bestDist <= gate) pts.push_back({p.pixel, best});
    }
    out.points = pts;
    out.fit = fitRings(out.points, out.distances, base, out.fit.centre, out.fit.radii, params.fit);
  }
  out.table = sectorTable(out.fit, out.points, base, params.sectors, params.radius_step);
  out.mirror = base;
  out.mirror.centre = out.fit.centre;
  out.mirror.axis_offset = out.fit.axis_offset;
  out.mirror.distance = camera::DistanceFunction(out.table.table);
  const double end = out.table.table.radii.back();
  out.mirror.useful_radius = std::min(base.useful_radius, end);
  if (!(out.mirror.useful_radius > out.mirror.self_radius)) {
    throw std::invalid_argument(fmt::format(
        "mirror calibration: the outermost ring ({:.1f} px) lies inside the robot's reflection "
        "({:.1f} px)",
        end, base.self_radius));
  }
  out.mirror.outer_radius = std::max(base.outer_radius, out.mirror.useful_radius);
  return out;
}

// --- files ---

namespace {

std::string list(const std::vector<double>& v, int decimals) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) {
    s += (i ? ", " : "") + fmt::format("{:.{}f}", v[i], decimals);
  }
  return s + "]";
}

}  // namespace

std::string cameraYaml(const camera::MirrorParams& m, const std::string& colour_table,
                       double frame_rate, double exposure, double latency,
                       const std::string& comment) {
  const auto* t = std::get_if<camera::CalibrationTableParams>(&m.distance.params());
  if (t == nullptr) throw std::invalid_argument("cameraYaml: the mirror has no calibration table");
  std::string s;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);)
    s += "# " + line + "\n";
  s += fmt::format("\nimage:\n  width: {}\n  height: {}\n\n", m.width, m.height);
  s += "mirror:\n";
  s += fmt::format("  centre: [{:.3f}, {:.3f}]\n", m.centre.x(), m.centre.y());
  s += fmt::format("  heading_angle: {:.6f}\n", m.heading_angle);
  s += fmt::format("  mirrored: {}\n", m.mirrored ? "true" : "false");
  s += fmt::format("  outer_radius: {:.3f}\n", m.outer_radius);
  // Rounded down: never beyond the table's last radius.
  s += fmt::format("  useful_radius: {:.3f}\n", std::floor(m.useful_radius * 1000.0) / 1000.0);
  s += fmt::format("  self_radius: {:.3f}\n", m.self_radius);
  s += fmt::format("  reference_height: {:.4f}\n", m.reference_height);
  s += "  # Where the mirror axis stands in the robot frame (x forward, y left), m.\n";
  s += fmt::format("  axis_offset: [{:.4f}, {:.4f}]\n", m.axis_offset.x(), m.axis_offset.y());
  s += "  distance_function:\n    type: table\n";
  s += "    radii: " + list(t->radii, 3) + "\n    sectors:\n";
  for (std::size_t k = 0; k < t->sector_bearings.size(); ++k) {
    // Rounded toward zero so that pi stays within the loader's range (-pi, pi].
    const double b = std::trunc(t->sector_bearings[k] * 1e9) / 1e9;
    s += fmt::format("      - bearing: {:.9f}\n", b);
    s += "        distances: " + list(t->distances[k], 4) + "\n";
  }
  s += fmt::format("\ncolour_table: {}\n\n", colour_table);
  s += fmt::format("pipeline:\n  frame_rate: {}\n  exposure: {}\n  latency: {}\n", frame_rate,
                   exposure, latency);
  return s;
}

std::vector<double> parseDistances(const std::string& text_or_path) {
  std::vector<double> out;
  std::ifstream file(text_or_path);
  if (file) {
    // `distN = value` lines, millimetres.
    const std::regex line(R"(^\s*dist\d+\s*=\s*([-+0-9.eE]+)\s*$)");
    std::string text;
    int lineNo = 0;
    while (std::getline(file, text)) {
      ++lineNo;
      std::smatch m;
      if (!std::regex_match(text, m, line)) continue;
      const double mm = std::stod(m[1].str());
      if (!std::isfinite(mm) || mm < 0.0) {
        throw std::invalid_argument(
            fmt::format("{}:{}: a ring distance must be >= 0 mm", text_or_path, lineNo));
      }
      if (mm > 0.0) out.push_back(mm / 1000.0);
    }
    if (out.empty()) {
      throw std::invalid_argument(text_or_path + ": no `distN = <mm>` lines with a distance > 0");
    }
  } else {
    std::stringstream in(text_or_path);
    for (std::string item; std::getline(in, item, ',');) {
      std::size_t used = 0;
      double v = kNaN;
      try {
        v = std::stod(item, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != item.size() || !std::isfinite(v) || v <= 0.0) {
        throw std::invalid_argument("ring distances: '" + item +
                                    "' is not a distance > 0 in metres (nor is '" + text_or_path +
                                    "' a readable file)");
      }
      out.push_back(v);
    }
  }
  std::sort(out.begin(), out.end());
  for (std::size_t i = 1; i < out.size(); ++i) {
    if (out[i] == out[i - 1]) throw std::invalid_argument("ring distances: a distance repeats");
  }
  return out;
}

}  // namespace fieldline::calibration
