#include "tools/mirror_calibrate/pose_free.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

#include <fmt/core.h>
#include <Eigen/Dense>

#include "common/field/distance_grid.hpp"
#include "common/geometry/fitting.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/mirror_calibrate/mirror_calibration.hpp"

namespace fieldline::calibration {

using camera::Vec2;
using geometry::Pose2;

namespace {

constexpr double kPi = std::numbers::pi;

// A ridge pixel of one frame with what the fit needs of it.
struct LinePx {
  Vec2 pixel = Vec2::Zero();
  int frame = 0;
  double width = 0.0;           // the ridge's width (above half height), px
  Vec2 across = Vec2::UnitX();  // the direction it was measured in (image)
  double radius = 0.0;          // from the current centre, px
  double bearing = 0.0;         // axis frame, rad
  // Association of the current round.
  Vec2 closest = Vec2::Zero();
  Vec2 normal = Vec2::UnitX();
  double mpp = 0.01;
  bool use = false;
};

// Truncated squared distance to the nearest line, on a raster over the carpet and beyond, for the
// pose lattice: one load per point.
class CostRaster {
 public:
  CostRaster(const field::FieldModel& field, double truncation, double cell, double margin)
      : cell_(cell) {
    const Vec2 half = field.carpetHalfExtent() + Vec2(margin, margin);
    origin_ = -half;
    cols_ = static_cast<int>(std::ceil(2 * half.x() / cell)) + 1;
    rows_ = static_cast<int>(std::ceil(2 * half.y() / cell)) + 1;
    const field::DistanceGrid grid(field, cell, margin + 1.0);
    cost_.resize(static_cast<std::size_t>(cols_) * rows_);
    const double t2 = truncation * truncation;
    for (int j = 0; j < rows_; ++j) {
      for (int i = 0; i < cols_; ++i) {
        const double d = grid.distance(origin_ + cell * Vec2(i, j));
        cost_[static_cast<std::size_t>(j) * cols_ + i] =
            static_cast<float>(std::min(d * d, t2) / t2);
      }
    }
  }
  float at(double x, double y) const {
    const int i = static_cast<int>((x - origin_.x()) / cell_ + 0.5);
    const int j = static_cast<int>((y - origin_.y()) / cell_ + 0.5);
    if (i < 0 || j < 0 || i >= cols_ || j >= rows_) return 1.0f;
    return cost_[static_cast<std::size_t>(j) * cols_ + i];
  }

 private:
  double cell_;
  Vec2 origin_;
  int cols_ = 0, rows_ = 0;
  std::vector<float> cost_;
};

// Geman-McClure cost of points seen from `pose` (field frame), mean over points.
double poseCost(const std::vector<Vec2>& pts, const Pose2& pose, const field::DistanceGrid& grid,
                double tau) {
  if (pts.empty()) return 1.0;
  double sum = 0.0;
  const double c = std::cos(pose.phi), s = std::sin(pose.phi);
  for (const Vec2& p : pts) {
    const Vec2 f(pose.x + c * p.x() - s * p.y(), pose.y + s * p.x() + c * p.y());
    const double d = grid.distance(f);
    sum += d * d / (d * d + tau * tau);
  }
  return sum / static_cast<double>(pts.size());
}

// Iteratively reweighted Gauss-Newton on the pose (Geman-McClure weights, scale tau).
Pose2 refinePose(const std::vector<Vec2>& pts, Pose2 pose, const field::DistanceGrid& grid,
                 double tau, int iterations) {
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    const double c = std::cos(pose.phi), s = std::sin(pose.phi);
    for (const Vec2& p : pts) {
      const Vec2 rot(c * p.x() - s * p.y(), s * p.x() + c * p.y());
      const Vec2 f = pose.position() + rot;
      const double d = grid.distance(f);
      const Vec2 grad = grid.gradient(f);
      const double w = tau * tau / ((d * d + tau * tau) * (d * d + tau * tau)) * tau * tau;
      const Eigen::Vector3d j(grad.x(), grad.y(), grad.x() * -rot.y() + grad.y() * rot.x());
      a += w * j * j.transpose();
      g += w * j * d;
    }
    a.diagonal().array() += 1e-6;
    const Eigen::Vector3d step = a.ldlt().solve(-g);
    if (!step.allFinite()) break;
    pose.x += step(0);
    pose.y += step(1);
    pose.phi = geometry::normalizeAngle(pose.phi + step(2));
    if (step.head<2>().norm() < 1e-4 && std::abs(step(2)) < 1e-4) break;
  }
  return pose;
}

Pose2 twinOf(const Pose2& p) {
  return {-p.x, -p.y, geometry::normalizeAngle(p.phi + kPi)};
}

struct Candidate {
  double k = 1.0;  // radius scale
  double s = 1.0;  // distance scale
};

// Robot-frame floor points of a frame's ridge pixels within `max_radius` of the centre under a
// candidate mirror (no offset). The same pixels for every candidate, so that a candidate cannot
// fit better by mapping the awkward ones out of range: a pixel the candidate puts beyond
// `max_distance` (or nowhere) stays, far off every line.
std::vector<Vec2> candidatePoints(const std::vector<LinePx>& px, int frame, const Candidate& c,
                                  const camera::MirrorParams& base, double max_radius,
                                  double max_distance, std::size_t limit) {
  std::vector<Vec2> all;
  for (const LinePx& p : px) {
    if (p.frame != frame || p.radius > max_radius) continue;
    double d = c.s * base.distance.floorDistance(p.radius / c.k, p.bearing);
    if (!std::isfinite(d) || d > max_distance) d = 1000.0;
    all.emplace_back(d * std::cos(p.bearing), d * std::sin(p.bearing));
  }
  if (all.size() <= limit || limit == 0) return all;
  std::vector<Vec2> out;
  const double stride = static_cast<double>(all.size()) / static_cast<double>(limit);
  for (std::size_t i = 0; i < limit; ++i)
    out.push_back(all[static_cast<std::size_t>(static_cast<double>(i) * stride)]);
  return out;
}

struct ScoredPose {
  Pose2 pose;
  double cost = 1.0;
};

// The best distinct poses of one frame's points: lattice, then the best refined.
std::vector<ScoredPose> searchPoses(const std::vector<Vec2>& pts, const std::vector<Vec2>& dense,
                                    const CostRaster& raster, const field::DistanceGrid& grid,
                                    const field::FieldModel& field, const PoseFreeParams& params,
                                    int keep) {
  std::vector<ScoredPose> lattice;
  if (pts.size() < 10) return lattice;
  // The robot stands on the field (the docs ask for it): within its lines and a little beyond.
  const Vec2 half(field.length() / 2 + 0.3, field.width() / 2 + 0.3);
  const int headings = static_cast<int>(std::lround(360.0 / params.search_heading_step_deg));
  const double step = params.search_position_step;
  // The K best lattice poses (a small sorted list), with early exit beyond the K-th.
  const std::size_t kBest = 16;
  std::vector<Vec2> rot(pts.size());
  const double n = static_cast<double>(pts.size());
  for (int h = 0; h < headings; ++h) {
    const double phi = 2 * kPi * h / headings;
    const double c = std::cos(phi), s = std::sin(phi);
    for (std::size_t i = 0; i < pts.size(); ++i)
      rot[i] = Vec2(c * pts[i].x() - s * pts[i].y(), s * pts[i].x() + c * pts[i].y());
    // x >= 0 only: the field's symmetric twin covers the other half.
    for (double x = 0.0; x <= half.x() + 1e-9; x += step) {
      for (double y = -half.y(); y <= half.y() + 1e-9; y += step) {
        const double bound =
            lattice.size() < kBest ? n : lattice.back().cost * n;  // costs stored as sums here
        double sum = 0.0;
        for (const Vec2& p : rot) {
          sum += raster.at(x + p.x(), y + p.y());
          if (sum >= bound) break;
        }
        if (sum >= bound) continue;
        ScoredPose sp{{x, y, geometry::normalizeAngle(phi)}, sum / n};
        const auto at = std::upper_bound(
            lattice.begin(), lattice.end(), sp,
            [](const ScoredPose& a, const ScoredPose& b) { return a.cost < b.cost; });
        lattice.insert(at, sp);
        if (lattice.size() > kBest) lattice.pop_back();
      }
    }
  }
  // Refine, then keep distinct poses (the twin counts as the same).
  std::vector<ScoredPose> refined;
  for (const ScoredPose& l : lattice) {
    Pose2 p = refinePose(dense, l.pose, grid, 0.4, 8);
    p = refinePose(dense, p, grid, 0.15, 8);
    refined.push_back({p, poseCost(dense, p, grid, 0.15)});
  }
  std::sort(refined.begin(), refined.end(),
            [](const ScoredPose& a, const ScoredPose& b) { return a.cost < b.cost; });
  std::vector<ScoredPose> out;
  for (const ScoredPose& r : refined) {
    bool same = false;
    for (const ScoredPose& o : out) {
      for (const Pose2& t : {o.pose, twinOf(o.pose)}) {
        if ((t.position() - r.pose.position()).norm() < 0.3 &&
            std::abs(geometry::angleDiff(t.phi, r.pose.phi)) < 0.1) {
          same = true;
        }
      }
    }
    if (!same) out.push_back(r);
    if (static_cast<int>(out.size()) >= keep) break;
  }
  return out;
}

// The curve D(r) through (0, 0) and (radii[k], distances[k]).
MonotoneCurve curveOf(const std::vector<double>& radii, const std::vector<double>& d) {
  std::vector<double> x{0.0};
  std::vector<double> y{0.0};
  x.insert(x.end(), radii.begin(), radii.end());
  y.insert(y.end(), d.begin(), d.end());
  return MonotoneCurve(x, y);
}

Vec2 lineNormalOf(const field::FieldModel& field, const field::FieldModel::Closest& c) {
  if (c.is_arc) {
    const field::LineArc& a = field.arcs()[static_cast<std::size_t>(c.element)];
    const Vec2 n = c.point - a.centre;
    return n.norm() > 1e-9 ? Vec2(n.normalized()) : Vec2::UnitX();
  }
  const field::LineSegment& l = field.segments()[static_cast<std::size_t>(c.element)];
  const Vec2 d = (l.b - l.a).normalized();
  return {-d.y(), d.x()};
}

// Circular spread of headings (rad): 2 pi minus the largest gap between them.
double headingSpread(std::vector<double> headings) {
  if (headings.size() < 2) return 0.0;
  for (double& h : headings)
    h = std::fmod(std::fmod(h, 2 * kPi) + 2 * kPi, 2 * kPi);
  std::sort(headings.begin(), headings.end());
  double gap = headings.front() + 2 * kPi - headings.back();
  for (std::size_t i = 1; i < headings.size(); ++i)
    gap = std::max(gap, headings[i] - headings[i - 1]);
  return 2 * kPi - gap;
}

// The state of the joint fit, packed into one vector:
//   [cx, cy, ox, oy, tx, ty, d_1 .. d_K, per spot: X, Y, per frame: phi or (X, Y, phi)]
// with (tx, ty) the tilt: the image radius a pixel's distance is read at grows by
// tx cos(a) + ty sin(a) px at image angle a (a tilted camera, or a mirror tilted on its mount,
// shifts the horizon toward one side; for an equiangular mirror this is exact).
constexpr int kFirstKnot = 6;
struct Layout {
  int knots = 0;
  std::vector<int> spot_of_frame;  // -1: the frame has its own position
  std::vector<int> frame_index;    // index of the frame's first own parameter
  std::vector<int> spot_index;     // index of each spot's X
  int size = 0;

  int knot(int k) const { return kFirstKnot + k; }
};

Pose2 poseOf(const Eigen::VectorXd& x, const Layout& l, int frame) {
  const int fi = l.frame_index[static_cast<std::size_t>(frame)];
  const int spot = l.spot_of_frame[static_cast<std::size_t>(frame)];
  if (spot >= 0) {
    const int si = l.spot_index[static_cast<std::size_t>(spot)];
    return {x(si), x(si + 1), x(fi)};
  }
  return {x(fi), x(fi + 1), x(fi + 2)};
}

}  // namespace

camera::MirrorParams scaleMirrorTo(const camera::MirrorParams& base, int width, int height) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("image size must be > 0");
  if (width == base.width && height == base.height) return base;
  const double factor =
      static_cast<double>(std::min(width, height)) / std::min(base.width, base.height);
  camera::MirrorParams p = base;
  p.width = width;
  p.height = height;
  const Vec2 oldMiddle(base.width / 2.0 - 0.5, base.height / 2.0 - 0.5);
  const Vec2 newMiddle(width / 2.0 - 0.5, height / 2.0 - 0.5);
  p.centre = newMiddle + (base.centre - oldMiddle) * factor;
  p.outer_radius *= factor;
  p.useful_radius *= factor;
  p.self_radius *= factor;
  p.distance = base.distance.scaled(factor);
  return p;
}

std::optional<Rim> findMirrorRim(const GreyImage& image, const Vec2& guess, double min_radius,
                                 double max_radius) {
  constexpr int kRays = 180;
  constexpr double kStep = 0.5;
  std::vector<Vec2> pts;
  for (int ray = 0; ray < kRays; ++ray) {
    const double a = 2 * kPi * ray / kRays;
    const Vec2 dir(std::cos(a), std::sin(a));
    std::vector<double> prof;
    for (double r = min_radius; r <= max_radius; r += kStep) {
      const Vec2 q = guess + r * dir;
      const double s = image.sample(q.x(), q.y());
      if (!std::isfinite(s)) break;
      prof.push_back(s);
    }
    const int n = static_cast<int>(prof.size());
    const int inside = static_cast<int>(8 / kStep);
    const int outside = static_cast<int>(6 / kStep);
    // The first place outward where the image drops to dark and stays dark to the end of the
    // ray (at least 6 px of it): beyond the mirror.
    std::vector<double> suffixMax(static_cast<std::size_t>(n) + 1, 0.0);
    for (int i = n - 1; i >= 0; --i)
      suffixMax[static_cast<std::size_t>(i)] =
          std::max(suffixMax[static_cast<std::size_t>(i) + 1], prof[static_cast<std::size_t>(i)]);
    for (int i = inside; i + outside < n; ++i) {
      double in = 0.0;
      for (int k = i - inside; k < i; ++k)
        in += prof[static_cast<std::size_t>(k)];
      in /= inside;
      const double beyond = suffixMax[static_cast<std::size_t>(i) + 2];
      if (in > 45.0 && beyond < 0.45 * in && beyond < 45.0) {
        // Sub-pixel: where the profile crosses halfway between inside and beyond.
        const double halfway = 0.5 * (in + beyond);
        int j = i;
        while (j > i - inside && prof[static_cast<std::size_t>(j)] < halfway)
          --j;
        const double a0 = prof[static_cast<std::size_t>(j)];
        const double a1 = prof[static_cast<std::size_t>(j) + 1];
        const double t = a0 > a1 ? (a0 - halfway) / (a0 - a1) : 0.5;
        pts.push_back(guess + (min_radius + (j + t) * kStep) * dir);
        break;
      }
    }
  }
  if (pts.size() < 30) return std::nullopt;
  Rim rim;
  std::vector<bool> keep;
  if (!geometry::fitCircleRobust(pts, rim.centre, rim.radius, keep, 1.5)) return std::nullopt;
  rim.rays = static_cast<int>(std::count(keep.begin(), keep.end(), true));
  if (rim.rays < 30) return std::nullopt;
  return rim;
}

PoseFreeCalibration calibrateAtUnknownPose(const std::vector<UnposedFrame>& frames,
                                           const field::FieldModel& field,
                                           const camera::MirrorParams& base_preset,
                                           const PoseFreeParams& params) {
  if (frames.empty()) throw std::invalid_argument("mirror calibration: no frames");
  const int w = frames[0].image.width;
  const int h = frames[0].image.height;
  for (const UnposedFrame& f : frames) {
    if (f.image.width != w || f.image.height != h) {
      throw std::invalid_argument(fmt::format(
          "mirror calibration: {} is {}x{}, the first frame {}x{}: all frames must come from "
          "one camera",
          f.name, f.image.width, f.image.height, w, h));
    }
  }
  if (params.rounds.empty() || params.radius_scales.empty() || params.distance_scales.empty()) {
    throw std::invalid_argument("mirror calibration: rounds and candidate scales expected");
  }
  PoseFreeCalibration out;
  camera::MirrorParams base = scaleMirrorTo(base_preset, w, h);
  const int nf = static_cast<int>(frames.size());

  // --- 1. the rim ---
  Vec2 centre = base.centre;
  double usableRadius = base.useful_radius;
  {
    std::vector<Vec2> centres;
    std::vector<double> radii;
    for (const UnposedFrame& f : frames) {
      if (const std::optional<Rim> rim = findMirrorRim(
              f.image, base.centre, 0.5 * base.outer_radius, std::hypot(w, h) / 2.0)) {
        if (rim->radius > 0.75 * base.outer_radius && rim->radius < 1.3 * base.outer_radius) {
          centres.push_back(rim->centre);
          radii.push_back(rim->radius);
        }
      }
    }
    if (!centres.empty()) {
      std::vector<double> cx, cy;
      for (const Vec2& c : centres) {
        cx.push_back(c.x());
        cy.push_back(c.y());
      }
      out.rim_found = true;
      out.rim_centre = Vec2(geometry::median(cx), geometry::median(cy));
      out.rim_radius = geometry::median(radii);
      centre = out.rim_centre;
      base.outer_radius = out.rim_radius;
      usableRadius = std::min(base.useful_radius, 0.97 * out.rim_radius);
    }
  }

  // --- 2. ridges on the floor ---
  // The floor's colour: the dominant colour near the robot (an annulus of image radii inside
  // which any omni-directional camera shows floor). Lines are ridges with floor on both sides;
  // ridges in the hall (people, walls, robots' tops) are not.
  std::vector<std::vector<camera::Yuv>> planes;
  for (const UnposedFrame& f : frames) {
    if (f.colour.size() == f.image.pixels.size()) {
      planes.push_back(f.colour);
    } else {
      std::vector<camera::Yuv> grey(f.image.pixels.size());
      for (std::size_t i = 0; i < grey.size(); ++i)
        grey[i] = camera::Yuv{f.image.pixels[i], 128, 128};
      planes.push_back(std::move(grey));
    }
  }
  {
    std::vector<std::uint8_t> near(static_cast<std::size_t>(w) * h, 0);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const double r = (Vec2(u, v) - centre).norm();
        near[static_cast<std::size_t>(v) * w + u] =
            r >= 1.3 * base.self_radius + 2.0 && r <= 0.55 * usableRadius;
      }
    }
    out.floor = findFloorColour(planes, near, 2);
  }
  RidgeParams rp = params.ridges;
  rp.centre = centre;
  rp.min_radius = std::max(rp.min_radius, 1.15 * base.self_radius + 2.0);
  rp.max_radius = std::min(rp.max_radius, usableRadius);
  std::vector<LinePx> pixels;
  std::vector<int> perFrame(static_cast<std::size_t>(nf), 0);
  auto collect = [&]() {
    pixels.clear();
    std::fill(perFrame.begin(), perFrame.end(), 0);
    for (int f = 0; f < nf; ++f) {
      const std::vector<camera::Yuv>& plane = planes[static_cast<std::size_t>(f)];
      for (const Ridge& r : findRidges(frames[static_cast<std::size_t>(f)].image, rp)) {
        bool onFloor = true;
        for (int side : {-1, 1}) {
          const Vec2 q = r.pixel + side * (r.half_width + 1.0) * r.normal;
          const int qu = static_cast<int>(std::lround(q.x()));
          const int qv = static_cast<int>(std::lround(q.y()));
          if (qu < 0 || qv < 0 || qu >= w || qv >= h) {
            onFloor = false;
            continue;
          }
          // The floor's chroma, and its luma within a factor of 1.5 either way of what it is
          // near the robot (vignetting and uneven light darken the far floor).
          const camera::Yuv& c = plane[static_cast<std::size_t>(qv) * w + qu];
          onFloor = onFloor && out.floor.chromaMatches(c) && c.y >= out.floor.luma_lo / 1.5 &&
                    c.y <= out.floor.luma_hi * 1.5;
        }
        if (!onFloor) continue;
        LinePx p;
        p.pixel = r.pixel;
        p.frame = f;
        p.width = r.width;
        p.across = r.normal;
        pixels.push_back(p);
        ++perFrame[static_cast<std::size_t>(f)];
      }
    }
  };
  collect();
  out.ridge_pixels = static_cast<int>(pixels.size());
  for (int f = 0; f < nf; ++f) {
    if (perFrame[static_cast<std::size_t>(f)] < 100) {
      throw Refusal(fmt::format(
          "{}: only {} bright ridges with floor on both sides (line pixels) between {:.0f} and "
          "{:.0f} px from the centre: an empty, dark or overexposed frame, or no field lines in "
          "view",
          frames[static_cast<std::size_t>(f)].name, perFrame[static_cast<std::size_t>(f)],
          rp.min_radius, rp.max_radius));
    }
  }
  auto setGeometry = [&](const Vec2& c) {
    for (LinePx& p : pixels) {
      p.radius = (p.pixel - c).norm();
      p.bearing = axisBearing(p.pixel, c, base.heading_angle, base.mirrored);
    }
  };
  setGeometry(centre);

  // --- 3. search over candidate mirrors and poses ---
  const field::DistanceGrid grid(field, 0.02, 3.0);
  const CostRaster raster(field, params.search_truncation, 0.05, 4.0);
  std::vector<Candidate> candidates;
  for (double k : params.radius_scales) {
    for (double s : params.distance_scales)
      candidates.push_back({k, s});
  }
  out.search.candidates = static_cast<int>(candidates.size());
  // The pixels every candidate is scored on: out to where the base camera sees
  // search_max_distance (at most 85 % of the usable radius).
  const double searchRadius = std::min(
      0.85 * usableRadius, std::isfinite(base.distance.imageRadius(params.search_max_distance, 0.0))
                               ? base.distance.imageRadius(params.search_max_distance, 0.0)
                               : usableRadius);
  // Frames the candidates are compared on first: those with the most ridges.
  std::vector<int> order(static_cast<std::size_t>(nf));
  for (int f = 0; f < nf; ++f)
    order[static_cast<std::size_t>(f)] = f;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return perFrame[static_cast<std::size_t>(a)] > perFrame[static_cast<std::size_t>(b)];
  });
  const int firstFrames = std::min(nf, std::max(1, params.search_frames));
  auto scoreCandidate = [&](const Candidate& c, const std::vector<int>& use, int keep,
                            std::vector<std::vector<ScoredPose>>* poses) {
    double total = 0.0;
    for (int f : use) {
      const std::vector<Vec2> coarse =
          candidatePoints(pixels, f, c, base, searchRadius, 4.0 * params.search_max_distance,
                          static_cast<std::size_t>(params.search_points));
      const std::vector<Vec2> dense =
          candidatePoints(pixels, f, c, base, searchRadius, 4.0 * params.search_max_distance, 400);
      std::vector<ScoredPose> found = searchPoses(coarse, dense, raster, grid, field, params, keep);
      total += found.empty() ? 1.0 : found.front().cost;
      if (poses) (*poses)[static_cast<std::size_t>(f)] = std::move(found);
    }
    return total / static_cast<double>(use.size());
  };
  std::vector<std::pair<double, std::size_t>> firstScores;
  const std::vector<int> first(order.begin(), order.begin() + firstFrames);
  for (std::size_t i = 0; i < candidates.size(); ++i)
    firstScores.emplace_back(scoreCandidate(candidates[i], first, 1, nullptr), i);
  std::sort(firstScores.begin(), firstScores.end());
  std::vector<int> all(static_cast<std::size_t>(nf));
  for (int f = 0; f < nf; ++f)
    all[static_cast<std::size_t>(f)] = f;
  double best = std::numeric_limits<double>::infinity();
  double second = best;
  Candidate winner;
  std::vector<std::vector<ScoredPose>> winnerPoses;
  const std::size_t survivors =
      std::min(firstScores.size(), static_cast<std::size_t>(std::max(1, params.search_survivors)));
  for (std::size_t i = 0; i < survivors; ++i) {
    std::vector<std::vector<ScoredPose>> poses(static_cast<std::size_t>(nf));
    const Candidate& c = candidates[firstScores[i].second];
    const double score = scoreCandidate(c, all, 4, &poses);
    if (score < best) {
      second = best;
      best = score;
      winner = c;
      winnerPoses = std::move(poses);
    } else {
      second = std::min(second, score);
    }
  }
  if (params.verbose) {
    for (int f = 0; f < nf; ++f) {
      fmt::print(stderr, "frame {}:", f);
      for (const ScoredPose& p : winnerPoses[static_cast<std::size_t>(f)])
        fmt::print(stderr, " ({:.2f},{:.2f},{:.0f} c{:.3f})", p.pose.x, p.pose.y,
                   p.pose.phi * 180 / kPi, p.cost);
      fmt::print(stderr, "\n");
    }
    for (auto& [sc, i] : firstScores)
      fmt::print(stderr, "cand k{:.2f} s{:.2f}: {:.3f}\n", candidates[i].k, candidates[i].s, sc);
    fmt::print(stderr, "winner k{:.2f} s{:.2f}: {:.3f}\n", winner.k, winner.s, best);
  }
  out.search.radius_scale = winner.k;
  out.search.distance_scale = winner.s;
  out.search.score = best;
  out.search.runner_up = second;
  if (!(best < 0.75)) {
    throw Refusal(fmt::format(
        "the frames' line pixels fit no pose on field '{}' under any candidate mirror (best mean "
        "cost {:.2f}, 0 = every pixel on a line, 1 = none): frames of another field, or no "
        "field lines in view",
        field.name(), best));
  }

  // --- 4. poses, frames at one spot linked ---
  // Groups: a spot's frames, or a frame on its own.
  std::vector<std::vector<int>> groups;
  std::vector<int> spotOf(static_cast<std::size_t>(nf), -1);
  {
    std::map<int, std::vector<int>> spots;
    for (int f = 0; f < nf; ++f) {
      if (frames[static_cast<std::size_t>(f)].spot >= 0) {
        spots[frames[static_cast<std::size_t>(f)].spot].push_back(f);
      } else {
        groups.push_back({f});
      }
    }
    int index = 0;
    for (const auto& [id, members] : spots) {
      for (int m : members)
        spotOf[static_cast<std::size_t>(m)] = index;
      groups.push_back(members);
      ++index;
    }
  }
  const int nspots =
      static_cast<int>(std::count_if(groups.begin(), groups.end(), [&](const auto& g) {
        return spotOf[static_cast<std::size_t>(g[0])] >= 0;
      }));
  // The poses of a group: every candidate pose (and twin) of every member as the anchor, the
  // others take their candidate nearest to it; the best total wins. `alternative`: the best
  // total with the group elsewhere (1 m or more from it and from its twin): a group whose
  // alternative fits about as well is ambiguous (an L of two lines fits at many corners).
  struct GroupPoses {
    std::vector<Pose2> poses;
    double total = std::numeric_limits<double>::infinity();
    double alternative = std::numeric_limits<double>::infinity();
  };
  auto linkGroup = [&](const std::vector<int>& members,
                       const std::vector<std::vector<ScoredPose>>& found) {
    struct Option {
      std::vector<Pose2> poses;
      double total;
      Vec2 at;
    };
    std::vector<Option> options;
    for (int anchorFrame : members) {
      for (const ScoredPose& a : found[static_cast<std::size_t>(anchorFrame)]) {
        for (const Pose2& anchor : {a.pose, twinOf(a.pose)}) {
          Option o{{}, 0.0, anchor.position()};
          for (int m : members) {
            double bestM = 2.0;
            Pose2 pick = anchor;
            for (const ScoredPose& c : found[static_cast<std::size_t>(m)]) {
              for (const Pose2& p : {c.pose, twinOf(c.pose)}) {
                const double apart = (p.position() - anchor.position()).norm();
                const double cost = c.cost + (apart < 0.6 ? apart : 1.0);
                if (cost < bestM) {
                  bestM = cost;
                  pick = p;
                }
              }
            }
            o.total += bestM;
            o.poses.push_back(pick);
          }
          o.total /= static_cast<double>(members.size());
          options.push_back(o);
        }
      }
    }
    GroupPoses g;
    for (const Option& o : options) {
      if (o.total < g.total) {
        g.total = o.total;
        g.poses = o.poses;
      }
    }
    if (g.poses.empty()) return g;
    const Vec2 at = g.poses.front().position();
    for (const Option& o : options) {
      if ((o.at - at).norm() >= 1.0 && (o.at + at).norm() >= 1.0) {
        g.alternative = std::min(g.alternative, o.total);
      }
    }
    return g;
  };
  std::vector<Pose2> start(static_cast<std::size_t>(nf));
  std::vector<bool> active(static_cast<std::size_t>(nf), false);
  // Groups by how well the search placed them: the joint fit starts from one of them.
  std::vector<std::pair<double, std::size_t>> seeds;
  {
    std::vector<GroupPoses> linked;
    for (const std::vector<int>& g : groups)
      linked.push_back(linkGroup(g, winnerPoses));
    for (std::size_t gi = 0; gi < groups.size(); ++gi) {
      const GroupPoses& lp = linked[gi];
      for (std::size_t i = 0; i < groups[gi].size(); ++i) {
        const int f = groups[gi][i];
        if (frames[static_cast<std::size_t>(f)].pose) {
          start[static_cast<std::size_t>(f)] = *frames[static_cast<std::size_t>(f)].pose;
          active[static_cast<std::size_t>(f)] = true;
        } else if (!lp.poses.empty()) {
          start[static_cast<std::size_t>(f)] = lp.poses[i];
        }
      }
      if (!lp.poses.empty()) seeds.emplace_back(lp.total, gi);
    }
    std::sort(seeds.begin(), seeds.end());
    if (seeds.empty() && std::none_of(active.begin(), active.end(), [](bool a) { return a; })) {
      throw Refusal("no pose on the field fits the frames' line pixels");
    }
  }

  // --- 5. the joint fit ---
  // Knots: from the winning candidate, those inside the usable radius.
  // Knots at fixed image radii (denser toward the rim, where the distance grows fastest); their
  // floor distances are fitted, starting from the winning candidate.
  std::vector<double> kr, kd;
  for (double q : params.knot_fractions) {
    const double r = q * usableRadius;
    double d = winner.s * base.distance.floorDistance(r / winner.k, 0.0);
    if (!std::isfinite(d) || d > params.max_table_distance * 2) d = params.max_table_distance * 2;
    if (!kd.empty()) d = std::max(d, kd.back() * 1.02 + 0.01);
    kr.push_back(r);
    kd.push_back(d);
  }
  if (kr.size() < 4) throw std::invalid_argument("mirror calibration: at least 4 knots");
  Layout layout;
  layout.knots = static_cast<int>(kd.size());
  layout.spot_of_frame = spotOf;
  int next = kFirstKnot + layout.knots;
  for (int s = 0; s < nspots; ++s) {
    layout.spot_index.push_back(next);
    next += 2;
  }
  for (int f = 0; f < nf; ++f) {
    layout.frame_index.push_back(next);
    next += spotOf[static_cast<std::size_t>(f)] >= 0 ? 1 : 3;
  }
  layout.size = next;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(layout.size);
  x(0) = centre.x();
  x(1) = centre.y();
  for (int k = 0; k < layout.knots; ++k)
    x(layout.knot(k)) = kd[static_cast<std::size_t>(k)];
  auto setPoses = [&](const std::vector<int>& which) {
    // A spot's position: the mean of its frames' positions.
    std::vector<Vec2> sum(static_cast<std::size_t>(nspots), Vec2::Zero());
    std::vector<int> count(static_cast<std::size_t>(nspots), 0);
    for (int f : which) {
      const int spot = spotOf[static_cast<std::size_t>(f)];
      if (spot < 0) continue;
      sum[static_cast<std::size_t>(spot)] += start[static_cast<std::size_t>(f)].position();
      ++count[static_cast<std::size_t>(spot)];
    }
    for (int sp = 0; sp < nspots; ++sp) {
      if (count[static_cast<std::size_t>(sp)] == 0) continue;
      const Vec2 m = sum[static_cast<std::size_t>(sp)] / count[static_cast<std::size_t>(sp)];
      x(layout.spot_index[static_cast<std::size_t>(sp)]) = m.x();
      x(layout.spot_index[static_cast<std::size_t>(sp)] + 1) = m.y();
    }
    for (int f : which) {
      const int fi = layout.frame_index[static_cast<std::size_t>(f)];
      const Pose2& p = start[static_cast<std::size_t>(f)];
      if (spotOf[static_cast<std::size_t>(f)] >= 0) {
        x(fi) = p.phi;
      } else {
        x(fi) = p.x;
        x(fi + 1) = p.y;
        x(fi + 2) = p.phi;
      }
    }
  };
  setPoses(all);

  // The offset is fitted when frames at one spot turned far enough to tell it from the pose.
  bool fitOffset = false;
  for (const std::vector<int>& g : groups) {
    if (spotOf[static_cast<std::size_t>(g[0])] < 0 || g.size() < 2) continue;
    std::vector<double> hs;
    for (int m : g)
      hs.push_back(start[static_cast<std::size_t>(m)].phi);
    if (headingSpread(hs) >= kPi / 3) fitOffset = true;
  }
  // A known pose pins the robot's centre: the offset follows from the lines.
  for (const UnposedFrame& f : frames) {
    if (f.pose) fitOffset = true;
  }
  if (params.offset == OffsetMode::kZero) fitOffset = false;
  if (params.offset == OffsetMode::kFit && !fitOffset) {
    throw Refusal(
        "--offset fit: the axis offset cannot be told from the robot's position unless frames "
        "were taken at one spot turning (give them with --spot, headings at least 60 degrees "
        "apart)");
  }

  auto curve = [&](const Eigen::VectorXd& v) {
    return curveOf(
        kr, std::vector<double>(v.data() + kFirstKnot, v.data() + kFirstKnot + layout.knots));
  };
  auto knotsValid = [&](const Eigen::VectorXd& v) {
    for (int k = 0; k < layout.knots; ++k) {
      if (!(v(layout.knot(k)) > (k == 0 ? 0.0 : v(layout.knot(k - 1)) * 1.001 + 1e-4))) {
        return false;
      }
    }
    return true;
  };
  // Smoothness: the log of the metres per pixel changes steadily from knot to knot (a kink costs
  // what a pixel of misfit costs, per `smoothness` of its second difference).
  // Smoothness (knots - 2 terms) and a pull toward the search's curve (knots terms, log ratio
  // 0.4 per unit: only a collapse of the scale feels it, which would otherwise pile every pixel
  // onto one line).
  const int priors = 2 * layout.knots - 2;
  const Eigen::VectorXd knotStart = x.segment(kFirstKnot, layout.knots);
  auto smoothness = [&](const double* d, Eigen::VectorXd& res, Eigen::Index at) {
    std::vector<double> logSlope;
    for (int k = 0; k < layout.knots; ++k) {
      const double r0 = k == 0 ? 0.0 : kr[static_cast<std::size_t>(k - 1)];
      const double d0 = k == 0 ? 0.0 : d[k - 1];
      logSlope.push_back(
          std::log(std::max(1e-9, (d[k] - d0) / (kr[static_cast<std::size_t>(k)] - r0))));
    }
    for (int k = 1; k + 1 < layout.knots; ++k) {
      res(at + k - 1) = params.smoothness * (logSlope[static_cast<std::size_t>(k + 1)] -
                                             2 * logSlope[static_cast<std::size_t>(k)] +
                                             logSlope[static_cast<std::size_t>(k - 1)]);
    }
    for (int k = 0; k < layout.knots; ++k) {
      res(at + layout.knots - 2 + k) = std::log(std::max(1e-9, d[k]) / knotStart(k)) / 0.4;
    }
  };
  // The radius a pixel's distance is read at: its image radius plus the tilt's share.
  auto tiltedRadius = [](const Eigen::VectorXd& v, const Vec2& pixel, const Vec2& ctr) {
    const Vec2 d = pixel - ctr;
    const double r = d.norm();
    return r > 1e-9 ? r + (v(4) * d.x() + v(5) * d.y()) / r : r;
  };
  auto fieldPoint = [&](const Eigen::VectorXd& v, const MonotoneCurve& c, const LinePx& p,
                        const Vec2& ctr) {
    const double r = tiltedRadius(v, p.pixel, ctr);
    const double b = axisBearing(p.pixel, ctr, base.heading_angle, base.mirrored);
    const double d = c(r);
    const Vec2 robot = Vec2(v(2), v(3)) + d * Vec2(std::cos(b), std::sin(b));
    return geometry::pointRobotToField(poseOf(v, layout, p.frame), robot);
  };
  double maxDistance = 0.0;
  auto associate = [&](const Eigen::VectorXd& v, const FitRound& round) {
    const MonotoneCurve c = curve(v);
    const Vec2 ctr(v(0), v(1));
    int used = 0;
    for (LinePx& p : pixels) {
      p.use = false;
      if (!active[static_cast<std::size_t>(p.frame)]) continue;
      const double r = tiltedRadius(v, p.pixel, ctr);
      const double d = c(r);
      if (!(d > 0.15) || d > round.max_distance_m) continue;
      p.mpp = std::max(1e-4, c(r + 0.5) - c(r - 0.5));
      const field::FieldModel::Closest cl = field.closestPoint(fieldPoint(v, c, p, ctr));
      p.closest = cl.point;
      p.normal = lineNormalOf(field, cl);
      p.use = cl.distance / p.mpp <= round.gate_px;
      used += p.use ? 1 : 0;
    }
    maxDistance = round.max_distance_m;
    return used;
  };
  const ResidualFunction residuals = [&](const Eigen::VectorXd& v, Eigen::VectorXd& res) {
    if (!knotsValid(v)) return false;
    const MonotoneCurve c = curve(v);
    const Vec2 ctr(v(0), v(1));
    const auto np = static_cast<Eigen::Index>(pixels.size());
    res.resize(np + priors + 4);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
      const LinePx& p = pixels[i];
      res(static_cast<Eigen::Index>(i)) =
          p.use ? (fieldPoint(v, c, p, ctr) - p.closest).dot(p.normal) / p.mpp : 0.0;
    }
    smoothness(v.data() + kFirstKnot, res, np);
    // The tilt is small (a few pixels at most), and the mirror's rim, where seen, is centred on
    // its axis within a pixel or so: both tell the tilt from a moved centre, which the lines
    // alone tell apart only by the bearings.
    res(np + priors) = v(4) / params.tilt_prior_px;
    res(np + priors + 1) = v(5) / params.tilt_prior_px;
    res(np + priors + 2) = out.rim_found ? (v(0) - out.rim_centre.x()) / params.rim_prior_px : 0.0;
    res(np + priors + 3) = out.rim_found ? (v(1) - out.rim_centre.y()) / params.rim_prior_px : 0.0;
    return true;
  };
  std::vector<double> steps(static_cast<std::size_t>(layout.size), 1e-4);
  auto setSteps = [&](bool offset, bool tilt) {
    std::fill(steps.begin(), steps.end(), 1e-4);
    steps[2] = steps[3] = offset ? 1e-5 : 0.0;
    steps[4] = steps[5] = tilt ? 1e-4 : 0.0;
    for (int f = 0; f < nf; ++f) {
      // A known pose stays as given; an inactive frame's pose waits.
      if (!frames[static_cast<std::size_t>(f)].pose && active[static_cast<std::size_t>(f)]) {
        continue;
      }
      const int fi = layout.frame_index[static_cast<std::size_t>(f)];
      const int own = spotOf[static_cast<std::size_t>(f)] >= 0 ? 1 : 3;
      for (int k = 0; k < own; ++k)
        steps[static_cast<std::size_t>(fi + k)] = 0.0;
    }
    for (int sp = 0; sp < nspots; ++sp) {
      bool any = false;
      for (int f = 0; f < nf; ++f) {
        any = any ||
              (spotOf[static_cast<std::size_t>(f)] == sp && active[static_cast<std::size_t>(f)]);
      }
      if (!any) {
        steps[static_cast<std::size_t>(layout.spot_index[static_cast<std::size_t>(sp)])] = 0.0;
        steps[static_cast<std::size_t>(layout.spot_index[static_cast<std::size_t>(sp)]) + 1] = 0.0;
      }
    }
  };
  int used = 0;
  auto runRounds = [&](std::size_t from) {
    for (std::size_t round = from; round < params.rounds.size(); ++round) {
      // The offset joins once the near field has settled the poses.
      setSteps(fitOffset && round >= 2, round >= 2);
      if (round == 2) {
        // Ridges searched again around the better centre (the annulus moves with it).
        rp.centre = Vec2(x(0), x(1));
        collect();
      }
      used = associate(x, params.rounds[round]);
      // Where the near field shows few lines, the round reaches further out.
      for (double extra = 0.5; used < 12 * layout.size && extra <= 3.0; extra += 0.5) {
        FitRound wider = params.rounds[round];
        wider.max_distance_m += extra;
        used = associate(x, wider);
      }
      if (params.verbose) {
        fmt::print(stderr, "round {}: {} used; active", round, used);
        for (int f = 0; f < nf; ++f)
          fmt::print(stderr, " {}", active[static_cast<std::size_t>(f)] ? 1 : 0);
        fmt::print(stderr, "; knots");
        for (int k = 0; k < layout.knots; ++k)
          fmt::print(stderr, " {:.2f}", x(layout.knot(k)));
        fmt::print(stderr, "\n");
      }
      if (used < 12 * layout.size) {
        throw Refusal(fmt::format(
            "only {} line pixels within {:.1f} px of a field line in round {} (of {} ridge "
            "pixels): the frames do not show field '{}' well enough",
            used, params.rounds[round].gate_px, round + 1, pixels.size(), field.name()));
      }
      x = levenbergMarquardt(x, residuals, steps, params.huber_px, params.iterations);
    }
  };
  // The seed: frames with known poses, else the group (a spot, or a frame) whose own fit puts
  // the largest share of its ridge pixels on the lines (of the three the search placed best).
  auto shareOnLines = [&]() {
    const MonotoneCurve c = curve(x);
    const Vec2 ctr(x(0), x(1));
    int inRange = 0;
    for (const LinePx& p : pixels) {
      if (!active[static_cast<std::size_t>(p.frame)]) continue;
      const double d = c(tiltedRadius(x, p.pixel, ctr));
      if (d > 0.15 && d <= maxDistance) ++inRange;
    }
    return inRange > 0 ? static_cast<double>(used) / inRange : 0.0;
  };
  if (std::none_of(active.begin(), active.end(), [](bool a) { return a; })) {
    const Eigen::VectorXd x0 = x;
    double bestShare = -1.0;
    Eigen::VectorXd bestX = x0;
    std::vector<bool> bestActive;
    std::vector<LinePx> bestPixels;
    for (std::size_t t = 0; t < std::min<std::size_t>(3, seeds.size()); ++t) {
      x = x0;
      std::fill(active.begin(), active.end(), false);
      for (int f : groups[seeds[t].second])
        active[static_cast<std::size_t>(f)] = true;
      double share = -1.0;
      try {
        runRounds(0);
        used = associate(x, params.rounds.back());
        share = shareOnLines();
      } catch (const Refusal&) {
        share = -1.0;
      }
      if (params.verbose) {
        fmt::print(stderr, "seed group {}: on lines {:.3f}\n", seeds[t].second, share);
      }
      if (share > bestShare) {
        bestShare = share;
        bestX = x;
        bestActive = active;
        bestPixels = pixels;
      }
    }
    if (bestShare < 0.0) {
      throw Refusal(fmt::format(
          "no spot or frame fits field '{}' on its own: the frames do not show the field well "
          "enough (stand where several lines are within 3 m)",
          field.name()));
    }
    x = bestX;
    active = bestActive;
    pixels = bestPixels;
  } else {
    runRounds(0);
  }
  // The frames left out (their place was ambiguous under the search's rough mirror): their poses
  // searched again with the fitted mirror and every line pixel up to its range, then all frames
  // fitted together.
  // A frame's line pixels as robot-frame points under the current state (at most `limit`,
  // evenly spread).
  auto robotPoints = [&](int f, std::size_t limit) {
    const MonotoneCurve c = curve(x);
    const Vec2 ctr(x(0), x(1));
    const Vec2 offset(x(2), x(3));
    const double reach =
        std::min(params.rounds.back().max_distance_m, x(layout.knot(layout.knots - 1)));
    std::vector<Vec2> pts;
    for (const LinePx& p : pixels) {
      if (p.frame != f) continue;
      const double d = c(tiltedRadius(x, p.pixel, ctr));
      if (!(d > 0.2) || d > reach) continue;
      const double b = axisBearing(p.pixel, ctr, base.heading_angle, base.mirrored);
      pts.push_back(offset + d * Vec2(std::cos(b), std::sin(b)));
    }
    if (pts.size() <= limit) return pts;
    std::vector<Vec2> some;
    for (std::size_t i = 0; i < limit; ++i)
      some.push_back(pts[i * pts.size() / limit]);
    return some;
  };
  // A frame turned on a spot: its heading scanned at the spot's position (1 degree steps).
  auto headingAt = [&](int f, const Vec2& at) {
    const std::vector<Vec2> pts = robotPoints(f, 400);
    double bestCost = 2.0, bestPhi = 0.0;
    for (int deg = 0; deg < 360; ++deg) {
      const double phi = deg * kPi / 180.0;
      const double c = poseCost(pts, Pose2{at.x(), at.y(), phi}, grid, 0.15);
      if (c < bestCost) {
        bestCost = c;
        bestPhi = phi;
      }
    }
    return geometry::normalizeAngle(bestPhi);
  };
  std::vector<int> waiting;
  for (int f = 0; f < nf; ++f) {
    if (!active[static_cast<std::size_t>(f)]) waiting.push_back(f);
  }
  if (!waiting.empty()) {
    std::vector<std::vector<ScoredPose>> found(static_cast<std::size_t>(nf));
    for (int f : waiting) {
      const std::vector<Vec2> pts = robotPoints(f, 100000);
      std::vector<Vec2> coarse;
      const std::size_t want = static_cast<std::size_t>(2 * params.search_points);
      for (std::size_t i = 0; i < want && !pts.empty(); ++i)
        coarse.push_back(pts[i * pts.size() / want]);
      std::vector<Vec2> dense;
      for (std::size_t i = 0; i < 600 && !pts.empty(); ++i)
        dense.push_back(pts[i * pts.size() / std::min<std::size_t>(600, pts.size())]);
      found[static_cast<std::size_t>(f)] =
          searchPoses(coarse, dense, raster, grid, field, params, 4);
    }
    for (const std::vector<int>& g : groups) {
      if (active[static_cast<std::size_t>(g[0])]) continue;
      const GroupPoses lp = linkGroup(g, found);
      if (lp.poses.empty()) continue;
      Vec2 at = Vec2::Zero();
      for (const Pose2& p : lp.poses)
        at += p.position();
      at /= static_cast<double>(lp.poses.size());
      for (std::size_t i = 0; i < g.size(); ++i) {
        start[static_cast<std::size_t>(g[i])] = lp.poses[i];
        // At a spot every frame stands at the spot's position: only its heading is searched.
        if (g.size() > 1)
          start[static_cast<std::size_t>(g[i])] = {at.x(), at.y(), headingAt(g[i], at)};
        active[static_cast<std::size_t>(g[i])] = true;
      }
      setPoses(g);
    }
    runRounds(1);
  }
  // A frame at a spot that still fits badly (its own candidates misled the linking): its heading
  // scanned again at the spot's fitted position, and the last rounds run again.
  {
    used = associate(x, params.rounds.back());
    std::vector<int> inRange(static_cast<std::size_t>(nf), 0),
        onLine(static_cast<std::size_t>(nf), 0);
    const MonotoneCurve c = curve(x);
    const Vec2 ctr(x(0), x(1));
    for (const LinePx& p : pixels) {
      const double d = c(tiltedRadius(x, p.pixel, ctr));
      if (!(d > 0.15) || d > maxDistance) continue;
      ++inRange[static_cast<std::size_t>(p.frame)];
      onLine[static_cast<std::size_t>(p.frame)] += p.use ? 1 : 0;
    }
    bool repaired = false;
    for (int f = 0; f < nf; ++f) {
      const int spot = spotOf[static_cast<std::size_t>(f)];
      if (spot < 0 || frames[static_cast<std::size_t>(f)].pose) continue;
      if (onLine[static_cast<std::size_t>(f)] >= 0.45 * inRange[static_cast<std::size_t>(f)])
        continue;
      const int si = layout.spot_index[static_cast<std::size_t>(spot)];
      x(layout.frame_index[static_cast<std::size_t>(f)]) = headingAt(f, Vec2(x(si), x(si + 1)));
      repaired = true;
    }
    if (repaired) runRounds(params.rounds.size() >= 3 ? params.rounds.size() - 3 : 0);
  }
  for (int f = 0; f < nf; ++f) {
    if (!active[static_cast<std::size_t>(f)]) {
      throw Refusal(frames[static_cast<std::size_t>(f)].name +
                    ": no pose on the field fits its line pixels");
    }
  }
  used = associate(x, params.rounds.back());

  // --- 6. uncertainty, the offset's verdict ---
  auto covariance = [&](const Eigen::VectorXd& v) {
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
    Eigen::MatrixXd cov = a.inverse() * sigma2 * inflation;
    for (int k = 0; k < layout.size; ++k) {
      if (steps[static_cast<std::size_t>(k)] == 0.0) {
        cov.row(k).setZero();
        cov.col(k).setZero();
      }
    }
    return cov;
  };
  Eigen::MatrixXd cov = covariance(x);
  out.offset_fitted = fitOffset;
  if (fitOffset) {
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
      x = levenbergMarquardt(x, residuals, steps, params.huber_px, params.iterations);
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

  // Knot support: line pixels used between each knot and the one before.
  const Vec2 ctr(x(0), x(1));
  const MonotoneCurve finalCurve = curve(x);
  (void)finalCurve;
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
  std::size_t lastSupported = 0;
  int unsupportedInARow = 0;
  bool started = false;
  for (std::size_t k = 0; k < kr.size(); ++k) {
    const bool supported = out.knot_support[k] >= params.min_knot_support &&
                           x(layout.knot(static_cast<int>(k))) <= params.max_table_distance;
    if (supported) {
      lastSupported = k;
      unsupportedInARow = 0;
      started = true;
    } else if (started && k >= 3 && ++unsupportedInARow >= 2) {
      break;
    }
  }
  out.knot_radii = kr;
  out.knot_distances.assign(x.data() + kFirstKnot, x.data() + kFirstKnot + layout.knots);
  out.table_end_m = out.knot_distances[lastSupported];

  // Sectors: each its own radii, blended between neighbours as the table does, poses fixed.
  const int ns = params.sectors;
  const int nk = layout.knots;
  const double width = 2.0 * kPi / ns;
  std::vector<double> bearings;
  for (int s = 0; s < ns; ++s)
    bearings.push_back(ns == 1 ? 0.0 : -kPi + width * (s + 1));
  struct Blend {
    std::size_t lower = 0, upper = 0;
    double w = 0.0;
  };
  std::vector<Blend> blends(pixels.size());
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    if (ns == 1) continue;
    const double b = axisBearing(pixels[i].pixel, ctr, base.heading_angle, base.mirrored);
    double from = std::remainder(b - bearings[0], 2 * kPi);
    if (from < 0.0) from += 2 * kPi;
    const auto lower = static_cast<std::size_t>(std::floor(from / width)) % ns;
    blends[i] = {lower, (lower + 1) % static_cast<std::size_t>(ns),
                 from / width - std::floor(from / width)};
  }
  Eigen::VectorXd xs(ns * nk);
  for (int s = 0; s < ns; ++s)
    xs.segment(s * nk, nk) = x.segment(kFirstKnot, nk);
  const ResidualFunction perSector = [&](const Eigen::VectorXd& v, Eigen::VectorXd& res) {
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
  };
  if (ns > 1) {
    xs = levenbergMarquardt(xs, perSector,
                            std::vector<double>(static_cast<std::size_t>(xs.size()), 1e-4),
                            params.huber_px, params.iterations);
  }
  // The table: common radii up to the last supported knot (the smallest over the sectors).
  camera::CalibrationTableParams table;
  const double end = kr[lastSupported];
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
  out.mirror.useful_radius = std::min(usableRadius, end);
  if (!(out.mirror.useful_radius > out.mirror.self_radius)) {
    throw Refusal("the fitted table ends inside the robot's reflection");
  }
  out.mirror.outer_radius = std::max(base.outer_radius, out.mirror.useful_radius);

  // Residuals and per-frame figures with the finished model.
  const camera::MirrorModel model(out.mirror);
  std::vector<double> fpx2(static_cast<std::size_t>(nf), 0.0);
  std::vector<int> fn(static_cast<std::size_t>(nf), 0), fin(static_cast<std::size_t>(nf), 0);
  double px2 = 0.0, m2 = 0.0;
  int n = 0, inRange = 0;
  for (const LinePx& p : pixels) {
    const std::optional<Vec2> robot = model.imageToRobot(p.pixel);
    if (!robot || robot->norm() > maxDistance) continue;
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
  // The lines' width: each near line pixel's ridge width against the width the field's line has
  // in the image there (its two edges mapped through the finished model). A field of another
  // size seen through a mirror stretched to fit it shows lines of the wrong width.
  {
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
      std::nth_element(ratios.begin(),
                       ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2),
                       ratios.end());
      out.line_width_ratio = ratios[ratios.size() / 2];
    }
  }
  for (int f = 0; f < nf; ++f) {
    FramePose fp;
    fp.name = frames[static_cast<std::size_t>(f)].name;
    fp.spot = frames[static_cast<std::size_t>(f)].spot;
    fp.pose = poseOf(x, layout, f);
    fp.pose.phi = geometry::normalizeAngle(fp.pose.phi);
    fp.twin = twinOf(fp.pose);
    const int fi = layout.frame_index[static_cast<std::size_t>(f)];
    const int spot = spotOf[static_cast<std::size_t>(f)];
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
  return out;
}

std::vector<std::string> weaknesses(const PoseFreeCalibration& c, const std::string& field_name) {
  std::vector<std::string> weak;
  if (c.rms_px > 1.0) {
    weak.push_back(fmt::format("rms {:.2f} px to the lines (at most 1)", c.rms_px));
  }
  if (c.on_lines < 0.6) {
    weak.push_back(
        fmt::format("only {:.0f} % of the ridge pixels lie on field lines (at least "
                    "60 %): frames of another field?",
                    100 * c.on_lines));
  }
  for (const FramePose& f : c.frames) {
    if (f.on_lines < 0.45 || f.points < 60) {
      weak.push_back(
          fmt::format("{}: {} line pixels, {:.0f} % of its ridges on lines: it does "
                      "not show field '{}'",
                      f.name, f.points, 100 * f.on_lines, field_name));
    }
  }
  if (c.width_samples >= 30 && (c.line_width_ratio < 0.85 || c.line_width_ratio > 1.25)) {
    weak.push_back(fmt::format(
        "the lines are {:.2f} times as wide as field '{}' paints them (median of {} near line "
        "pixels): frames of another field, or a mirror scaled to fit the wrong one",
        c.line_width_ratio, field_name, c.width_samples));
  }
  if (c.table_end_m < 3.0) {
    weak.push_back(
        fmt::format("the line pixels reach only {:.2f} m (a table to 3 m or more is "
                    "needed): frames with lines further out",
                    c.table_end_m));
  }
  return weak;
}

}  // namespace fieldline::calibration
