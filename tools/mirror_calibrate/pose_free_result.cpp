// Stage 6 of the mirror calibration at an unknown pose (pose_free_solver.hpp): the fit's
// uncertainty and the offset's verdict, how far the table reaches, the radii per bearing sector
// and the table, the figures of the finished model.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <set>
#include <utility>

#include <fmt/core.h>
#include <Eigen/Dense>

#include "tools/calibration_common/percentile.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/mirror_calibrate/numbers.hpp"
#include "tools/mirror_calibrate/pose_free_solver.hpp"

namespace fieldline::calibration::posefree {

// The covariance of the state from the fit's curvature, inflated for neighbouring pixels'
// correlated errors; zero for the parameters held fixed.
Eigen::MatrixXd Solver::covariance(const Eigen::VectorXd& v) const {
  Eigen::VectorXd r0;
  residuals(v, r0);
  const Eigen::Index n = r0.size();
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(n, layout.size);
  for (int k = 0; k < layout.size; ++k) {
    const double hstep = steps[static_cast<std::size_t>(k)];
    if (hstep == 0.0) continue;
    Eigen::VectorXd vp = v;
    vp(k) += hstep;
    Eigen::VectorXd rp2;
    if (residuals(vp, rp2)) j.col(k) = (rp2 - r0) / hstep;
  }
  double wr2 = 0.0;
  int m = 0;
  Eigen::VectorXd wts = Eigen::VectorXd::Zero(n);
  std::set<std::pair<int, int>> cells;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    if (!pixels[i].use) continue;
    const double a = std::abs(r0(static_cast<Eigen::Index>(i)));
    const double wi = a <= params.huber_px ? 1.0 : params.huber_px / a;
    wts(static_cast<Eigen::Index>(i)) = wi;
    wr2 += wi * a * a;
    ++m;
    cells.insert({pixels[i].frame * 100000 + static_cast<int>(pixels[i].pixel.x() / 8),
                  static_cast<int>(pixels[i].pixel.y() / 8)});
  }
  for (int k = 0; k < priors + 4; ++k)
    wts(static_cast<Eigen::Index>(pixels.size()) + k) = 1.0;
  Eigen::MatrixXd a = j.transpose() * wts.asDiagonal() * j;
  for (int k = 0; k < layout.size; ++k)
    if (a(k, k) <= 0.0) a(k, k) = 1.0;
  const double sigma2 = wr2 / std::max(1, m - layout.size);
  // Neighbouring pixels of one line share their error: count 8x8 px cells, not pixels.
  const double inflation = static_cast<double>(m) / std::max<std::size_t>(1, cells.size());
  Eigen::MatrixXd result = a.inverse() * sigma2 * inflation;
  for (int k = 0; k < layout.size; ++k) {
    if (steps[static_cast<std::size_t>(k)] == 0.0) {
      result.row(k).setZero();
      result.col(k).setZero();
    }
  }
  return result;
}

// The offset is kept only when the data pins it; else it is held at 0 and the fit run again.
void Solver::judgeOffset() {
  cov = covariance(x);
  out.offset_fitted = fit_offset;
  if (fit_offset) {
    out.offset_covariance = cov.block<2, 2>(2, 2);
    const double sx = std::sqrt(out.offset_covariance(0, 0));
    const double sy = std::sqrt(out.offset_covariance(1, 1));
    if (!(std::max(sx, sy) <= params.offset_sigma_limit)) {
      if (params.offset == OffsetMode::kFit) {
        throw Refusal(fmt::format(
            "--offset fit: the data does not pin the axis offset ({:.1f}, {:.1f}) cm: its "
            "standard deviation is {:.1f} / {:.1f} cm (limit {:.1f} cm); take more frames at one "
            "spot, turning all the way round",
            100 * x(2), 100 * x(3), 100 * sx, 100 * sy, 100 * params.offset_sigma_limit));
      }
      out.offset_note = fmt::format(
          "not pinned by the data (fitted ({:.1f}, {:.1f}) cm with standard deviation {:.1f} / "
          "{:.1f} cm > {:.1f} cm): held at 0",
          100 * x(2), 100 * x(3), 100 * sx, 100 * sy, 100 * params.offset_sigma_limit);
      out.offset_fitted = false;
      x(2) = x(3) = 0.0;
      setSteps(false, true);
      x = levenbergMarquardt(x, residualFunction(), steps, params.huber_px, params.iterations);
      used = associate(x, params.rounds.back());
      cov = covariance(x);
    } else {
      out.offset_note =
          fmt::format("fitted, standard deviation {:.1f} / {:.1f} cm", 100 * sx, 100 * sy);
    }
  } else {
    out.offset_note =
        params.offset == OffsetMode::kZero
            ? "held at 0 (--offset zero)"
            : "held at 0: no frames turning on one spot, so the offset cannot be told from the "
              "robot's position (the poses below are the mirror axis')";
  }
  out.offset = Vec2(x(2), x(3));
  out.centre_sigma_px = std::sqrt(std::max(0.0, cov(0, 0) + cov(1, 1)));
}

// Knot support: line pixels used between each knot and the one before.
void Solver::findTableEnd() {
  const Vec2 ctr(x(0), x(1));
  out.knot_support.assign(kr.size(), 0);
  for (const LinePx& p : pixels) {
    if (!p.use) continue;
    const double r = tiltedRadius(x, p.pixel, ctr);
    for (std::size_t k = 0; k < kr.size(); ++k) {
      if (r <= kr[k]) {
        ++out.knot_support[k];
        break;
      }
    }
  }
  // The table reaches as far as the knots are supported without a hole (two knots in a row
  // without line pixels leave the distance function there to the smoothness prior alone). Near the
  // robot there are often no lines: no hole counts before the first supported knot, nor among
  // the first three.
  last_supported = 0;
  int unsupportedInARow = 0;
  bool started = false;
  for (std::size_t k = 0; k < kr.size(); ++k) {
    const bool supported = out.knot_support[k] >= params.min_knot_support &&
                           x(layout.knot(static_cast<int>(k))) <= params.max_table_distance;
    if (supported) {
      last_supported = k;
      unsupportedInARow = 0;
      started = true;
    } else if (started && k >= 3 && ++unsupportedInARow >= 2) {
      break;
    }
  }
  out.knot_radii = kr;
  out.knot_distances.assign(x.data() + kFirstKnot, x.data() + kFirstKnot + layout.knots);
  out.table_end_m = out.knot_distances[last_supported];
}

// Sectors: each its own radii, blended between neighbours as the table does, poses fixed.
void Solver::fitSectors() {
  const Vec2 ctr(x(0), x(1));
  ns = params.sectors;
  nk = layout.knots;
  const double width = 2.0 * kPi / ns;
  bearings.clear();
  for (int s = 0; s < ns; ++s)
    bearings.push_back(ns == 1 ? 0.0 : -kPi + width * (s + 1));
  blends.assign(pixels.size(), Blend{});
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    if (ns == 1) continue;
    const double b = axisBearing(pixels[i].pixel, ctr, base.heading_angle, base.mirrored);
    double from = std::remainder(b - bearings[0], 2 * kPi);
    if (from < 0.0) from += 2 * kPi;
    const auto lower = static_cast<std::size_t>(std::floor(from / width)) % ns;
    blends[i] = {lower, (lower + 1) % static_cast<std::size_t>(ns),
                 from / width - std::floor(from / width)};
  }
  xs = Eigen::VectorXd(ns * nk);
  for (int s = 0; s < ns; ++s)
    xs.segment(s * nk, nk) = x.segment(kFirstKnot, nk);
  const ResidualFunction perSector = [this](const Eigen::VectorXd& v, Eigen::VectorXd& res) {
    return sectorResiduals(v, res);
  };
  if (ns > 1) {
    xs = levenbergMarquardt(xs, perSector,
                            std::vector<double>(static_cast<std::size_t>(xs.size()), 1e-4),
                            params.huber_px, params.iterations);
  }
}

bool Solver::sectorResiduals(const Eigen::VectorXd& v, Eigen::VectorXd& res) const {
  const Vec2 ctr(x(0), x(1));
  std::vector<MonotoneCurve> curves;
  for (int s = 0; s < ns; ++s) {
    std::vector<double> d(v.data() + s * nk, v.data() + (s + 1) * nk);
    for (std::size_t k = 0; k < d.size(); ++k)
      if (!(d[k] > (k == 0 ? 0.0 : d[k - 1] * 1.001 + 1e-4))) return false;
    curves.push_back(curveOf(kr, d));
  }
  res.resize(static_cast<Eigen::Index>(pixels.size()) + ns * nk + ns * priors);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const LinePx& p = pixels[i];
    double r = 0.0;
    if (p.use) {
      const Blend& bl = blends[i];
      const double rad = tiltedRadius(x, p.pixel, ctr);
      const double dist = (1 - bl.w) * curves[bl.lower](rad) + bl.w * curves[bl.upper](rad);
      const double b = axisBearing(p.pixel, ctr, base.heading_angle, base.mirrored);
      const Vec2 f = geometry::pointRobotToField(
          poseOf(x, layout, p.frame), out.offset + dist * Vec2(std::cos(b), std::sin(b)));
      r = (f - p.closest).dot(p.normal) / p.mpp;
    }
    res(static_cast<Eigen::Index>(i)) = r;
  }
  // Near the common curve: a sector's distance off by one pixel's worth costs sector_prior_px.
  for (Eigen::Index k = 0; k < ns * nk; ++k) {
    const int kk = static_cast<int>(k % nk);
    const double r0 = kk == 0 ? 0.0 : kr[static_cast<std::size_t>(kk - 1)];
    const double d0 = kk == 0 ? 0.0 : x(kFirstKnot + kk - 1);
    const double mpp = (x(kFirstKnot + kk) - d0) / (kr[static_cast<std::size_t>(kk)] - r0);
    res(static_cast<Eigen::Index>(pixels.size()) + k) =
        (v(k) - x(kFirstKnot + kk)) / mpp / params.sector_prior_px;
  }
  for (int s = 0; s < ns; ++s) {
    smoothness(v.data() + s * nk, res,
               static_cast<Eigen::Index>(pixels.size()) + ns * nk + s * priors);
  }
  return true;
}

// The table: common radii up to the last supported knot (the smallest over the sectors).
void Solver::writeTable() {
  const Vec2 ctr(x(0), x(1));
  camera::CalibrationTableParams table;
  const double end = kr[last_supported];
  // From the robot's reflection on (no floor is seen inside it; the table runs linearly to 0).
  const double innermost = std::max(params.radius_step, std::ceil(base.self_radius));
  for (double rad = innermost; rad < end - 0.5; rad += params.radius_step)
    table.radii.push_back(rad);
  table.radii.push_back(end);
  for (int s = 0; s < ns; ++s) {
    const MonotoneCurve c =
        curveOf(kr, std::vector<double>(xs.data() + s * nk, xs.data() + (s + 1) * nk));
    // The tilt along this sector's image direction.
    const double b = bearings[static_cast<std::size_t>(s)];
    const double a = base.heading_angle + (base.mirrored ? b : -b);
    const double shift = x(4) * std::cos(a) + x(5) * std::sin(a);
    std::vector<double> dist;
    for (double rad : table.radii)
      dist.push_back(c(rad + shift));
    table.sector_bearings.push_back(b);
    table.distances.push_back(dist);
  }
  out.tilt_px = Vec2(x(4), x(5));
  out.mirror = base;
  out.mirror.centre = ctr;
  out.mirror.axis_offset = out.offset;
  out.mirror.distance = camera::DistanceFunction(table);
  out.mirror.useful_radius = std::min(usable_radius, end);
  if (!(out.mirror.useful_radius > out.mirror.self_radius)) {
    throw Refusal("the fitted table ends inside the robot's reflection");
  }
  out.mirror.outer_radius = std::max(base.outer_radius, out.mirror.useful_radius);
}

// Residuals and per-frame figures with the finished model.
void Solver::measure() {
  const camera::MirrorModel model(out.mirror);
  std::vector<double> fpx2(static_cast<std::size_t>(nf), 0.0);
  std::vector<int> fn(static_cast<std::size_t>(nf), 0), fin(static_cast<std::size_t>(nf), 0);
  double px2 = 0.0, m2 = 0.0;
  int n = 0, inRange = 0;
  for (const LinePx& p : pixels) {
    const std::optional<Vec2> robot = model.imageToRobot(p.pixel);
    if (!robot || robot->norm() > max_distance) continue;
    ++inRange;
    ++fin[static_cast<std::size_t>(p.frame)];
    if (!p.use) continue;
    const double e =
        field.distance(geometry::pointRobotToField(poseOf(x, layout, p.frame), *robot));
    const double mpp = model.metresPerPixel(p.pixel).x();
    if (!(mpp > 0.0)) continue;
    px2 += (e / mpp) * (e / mpp);
    m2 += e * e;
    ++n;
    fpx2[static_cast<std::size_t>(p.frame)] += (e / mpp) * (e / mpp);
    ++fn[static_cast<std::size_t>(p.frame)];
  }
  out.used = n;
  out.rms_px = n > 0 ? std::sqrt(px2 / n) : 0.0;
  out.rms_cm = n > 0 ? 100.0 * std::sqrt(m2 / n) : 0.0;
  out.on_lines = inRange > 0 ? static_cast<double>(n) / inRange : 0.0;
  measureLineWidth(model);
  reportFrames(fpx2, fn, fin);
}

// The lines' width: each near line pixel's ridge width against the width the field's line has
// in the image there (its two edges mapped through the finished model). A field of another
// size seen through a mirror stretched to fit it shows lines of the wrong width.
void Solver::measureLineWidth(const camera::MirrorModel& model) {
  std::vector<double> ratios;
  for (const LinePx& p : pixels) {
    if (!p.use) continue;
    const Pose2 pose = poseOf(x, layout, p.frame);
    const field::FieldModel::Closest cl = field.closestPoint(p.closest);
    const double half =
        0.5 * (cl.is_arc ? field.arcs()[static_cast<std::size_t>(cl.element)].width
                         : field.segments()[static_cast<std::size_t>(cl.element)].width);
    const std::optional<Vec2> a =
        model.robotToImage(geometry::pointFieldToRobot(pose, p.closest - half * p.normal));
    const std::optional<Vec2> b =
        model.robotToImage(geometry::pointFieldToRobot(pose, p.closest + half * p.normal));
    if (!a || !b) continue;
    const Vec2 span = *b - *a;
    // Measured along the ridge's direction: the image width across the line, seen at the
    // angle between that direction and the line's normal in the image.
    const double cosine = std::abs(span.normalized().dot(p.across));
    if (span.norm() < 3.0 || cosine < 0.7) continue;
    ratios.push_back(p.width * cosine / span.norm());
  }
  out.width_samples = static_cast<int>(ratios.size());
  if (ratios.size() >= 30) {
    out.line_width_ratio = upperMedian(std::move(ratios));
  }
}

void Solver::reportFrames(const std::vector<double>& fpx2, const std::vector<int>& fn,
                          const std::vector<int>& fin) {
  for (int f = 0; f < nf; ++f) {
    FramePose fp;
    fp.name = frames[static_cast<std::size_t>(f)].name;
    fp.spot = frames[static_cast<std::size_t>(f)].spot;
    fp.pose = poseOf(x, layout, f);
    fp.pose.phi = geometry::normalizeAngle(fp.pose.phi);
    fp.twin = twinOf(fp.pose);
    const int fi = layout.frame_index[static_cast<std::size_t>(f)];
    const int spot = spot_of[static_cast<std::size_t>(f)];
    const int xi = spot >= 0 ? layout.spot_index[static_cast<std::size_t>(spot)] : fi;
    const int pi = spot >= 0 ? fi : fi + 2;
    fp.sigma = Eigen::Vector3d(std::sqrt(std::max(0.0, cov(xi, xi))),
                               std::sqrt(std::max(0.0, cov(xi + 1, xi + 1))),
                               std::sqrt(std::max(0.0, cov(pi, pi))));
    fp.points = fn[static_cast<std::size_t>(f)];
    fp.rms_px = fp.points > 0 ? std::sqrt(fpx2[static_cast<std::size_t>(f)] / fp.points) : 0.0;
    fp.on_lines = fin[static_cast<std::size_t>(f)] > 0
                      ? static_cast<double>(fp.points) / fin[static_cast<std::size_t>(f)]
                      : 0.0;
    out.frames.push_back(fp);
  }
}

}  // namespace fieldline::calibration::posefree
