// Mirror calibration, stage 5: the monotone distance curve and the table of image radius to floor
// distance per bearing sector.
#include "tools/mirror_calibrate/mirror_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "common/geometry/fitting.hpp"
#include "tools/mirror_calibrate/numbers.hpp"

namespace fieldline::calibration {

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

// --- stage 5: the table per sector ---

namespace {

// The sectors' bearings (each sector's centre) and the sector a bearing falls in.
struct Sectors {
  std::vector<double> bearings;

  explicit Sectors(int count) {
    const double width = 2.0 * kPi / count;
    for (int s = 0; s < count; ++s)
      bearings.push_back(count == 1 ? 0.0 : -kPi + width * (s + 1));
  }
  int count() const { return static_cast<int>(bearings.size()); }
  int of(double b) const {
    if (count() == 1) return 0;
    int best = 0;
    for (int s = 1; s < count(); ++s) {
      if (std::abs(geometry::normalizeAngle(b - bearings[static_cast<std::size_t>(s)])) <
          std::abs(geometry::normalizeAngle(b - bearings[static_cast<std::size_t>(best)]))) {
        best = s;
      }
    }
    return best;
  }
};

// The residuals of the finished table `out`, per sector and in total, over the fit's inliers
// (whose bearings are `bearing_of_point`).
void addResiduals(const RingFit& fit, const std::vector<RingPoint>& points,
                  const std::vector<double>& bearing_of_point, const Sectors& sectors,
                  SectorTable& out) {
  const std::size_t nr = fit.distances.size();
  const camera::DistanceFunction table{out.table};
  struct Acc {
    int n = 0;
    double px2 = 0, pc2 = 0, maxp = 0, maxcm = 0;
    std::vector<bool> rings;
  };
  std::vector<Acc> acc(static_cast<std::size_t>(sectors.count()) + 1);
  for (Acc& a : acc)
    a.rings.assign(nr, false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!fit.inlier.empty() && !fit.inlier[i]) continue;
    const double b = bearing_of_point[i];
    const double rad = (points[i].pixel - fit.centre).norm();
    const double t = axisDistanceToRing(fit.distances[static_cast<std::size_t>(points[i].ring)], b,
                                        fit.axis_offset);
    const double dist = table.floorDistance(rad, b);
    const double rr = table.imageRadius(t, b);
    if (!std::isfinite(dist) || !std::isfinite(rr)) continue;
    const double pc = 100.0 * std::abs(dist - t) / t;
    for (Acc* a : {&acc[static_cast<std::size_t>(sectors.of(b))], &acc.back()}) {
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
  for (int s = 0; s < sectors.count(); ++s) {
    out.residuals.push_back(
        summary(acc[static_cast<std::size_t>(s)], sectors.bearings[static_cast<std::size_t>(s)]));
  }
  out.total = summary(acc.back(), 0.0);
}

}  // namespace

SectorTable sectorTable(const RingFit& fit, const std::vector<RingPoint>& points,
                        const camera::MirrorParams& base, int sectors, double radius_step) {
  if (sectors < 1 || sectors > 360 || !(radius_step > 0.0)) {
    throw std::invalid_argument("sector table: sectors in 1..360 and radius_step > 0 expected");
  }
  const std::size_t nr = fit.distances.size();
  const Sectors sector_set(sectors);
  const std::vector<double>& bearings = sector_set.bearings;
  // Per sector and ring: radii moved to the sector's bearing with the global fit.
  std::vector<std::vector<std::vector<double>>> moved(static_cast<std::size_t>(sectors),
                                                      std::vector<std::vector<double>>(nr));
  std::vector<double> bearingOfPoint(points.size(), 0.0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double b = axisBearing(points[i].pixel, fit.centre, base.heading_angle, base.mirrored);
    bearingOfPoint[i] = b;
    if (!fit.inlier.empty() && !fit.inlier[i]) continue;
    const int s = sector_set.of(b);
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
      double rk = moved[su][k].size() >= 3 ? geometry::median(moved[su][k]) : kNaN;
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
  addResiduals(fit, points, bearingOfPoint, sector_set, out);
  return out;
}

}  // namespace fieldline::calibration
