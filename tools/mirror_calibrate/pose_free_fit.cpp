// Stage 5 of the mirror calibration at an unknown pose (pose_free_solver.hpp): the joint fit of
// the centre, the distance knots, every pose and the axis offset, from the search's start.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>
#include <Eigen/Dense>

#include "tools/calibration_common/staged_output.hpp"
#include "tools/mirror_calibrate/numbers.hpp"
#include "tools/mirror_calibrate/pose_free_solver.hpp"

namespace fieldline::calibration::posefree {

namespace {

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

}  // namespace

// The curve D(r) through (0, 0) and (radii[k], distances[k]).
MonotoneCurve curveOf(const std::vector<double>& radii, const std::vector<double>& d) {
  std::vector<double> x{0.0};
  std::vector<double> y{0.0};
  x.insert(x.end(), radii.begin(), radii.end());
  y.insert(y.end(), d.begin(), d.end());
  return MonotoneCurve(x, y);
}

Pose2 poseOf(const Eigen::VectorXd& x, const Layout& l, int frame) {
  const int fi = l.frame_index[static_cast<std::size_t>(frame)];
  const int spot = l.spot_of_frame[static_cast<std::size_t>(frame)];
  if (spot >= 0) {
    const int si = l.spot_index[static_cast<std::size_t>(spot)];
    return {x(si), x(si + 1), x(fi)};
  }
  return {x(fi), x(fi + 1), x(fi + 2)};
}

// The radius a pixel's distance is read at: its image radius plus the tilt's share.
double tiltedRadius(const Eigen::VectorXd& v, const Vec2& pixel, const Vec2& ctr) {
  const Vec2 d = pixel - ctr;
  const double r = d.norm();
  return r > 1e-9 ? r + (v(4) * d.x() + v(5) * d.y()) / r : r;
}

// Knots at fixed image radii (denser toward the rim, where the distance grows fastest); their
// floor distances are fitted, starting from the winning candidate. The state starts from the
// search's poses.
void Solver::setUpJointFit() {
  std::vector<double> kd;
  for (double q : params.knot_fractions) {
    const double r = q * usable_radius;
    double d = winner.s * base.distance.floorDistance(r / winner.k, 0.0);
    if (!std::isfinite(d) || d > params.max_table_distance * 2) d = params.max_table_distance * 2;
    if (!kd.empty()) d = std::max(d, kd.back() * 1.02 + 0.01);
    kr.push_back(r);
    kd.push_back(d);
  }
  if (kr.size() < 4) throw std::invalid_argument("mirror calibration: at least 4 knots");
  layout.knots = static_cast<int>(kd.size());
  layout.spot_of_frame = spot_of;
  int next = kFirstKnot + layout.knots;
  for (int s = 0; s < nspots; ++s) {
    layout.spot_index.push_back(next);
    next += 2;
  }
  for (int f = 0; f < nf; ++f) {
    layout.frame_index.push_back(next);
    next += spot_of[static_cast<std::size_t>(f)] >= 0 ? 1 : 3;
  }
  layout.size = next;
  x = Eigen::VectorXd::Zero(layout.size);
  x(0) = centre.x();
  x(1) = centre.y();
  for (int k = 0; k < layout.knots; ++k)
    x(layout.knot(k)) = kd[static_cast<std::size_t>(k)];
  std::vector<int> all(static_cast<std::size_t>(nf));
  for (int f = 0; f < nf; ++f)
    all[static_cast<std::size_t>(f)] = f;
  setPoses(all);
  // Smoothness (knots - 2 terms) and a pull toward the search's curve (knots terms, log ratio
  // 0.4 per unit: only a collapse of the scale feels it, which would otherwise pile every pixel
  // onto one line).
  priors = 2 * layout.knots - 2;
  knot_start = x.segment(kFirstKnot, layout.knots);
  steps.assign(static_cast<std::size_t>(layout.size), 1e-4);
}

void Solver::setPoses(const std::vector<int>& which) {
  // A spot's position: the mean of its frames' positions.
  std::vector<Vec2> sum(static_cast<std::size_t>(nspots), Vec2::Zero());
  std::vector<int> count(static_cast<std::size_t>(nspots), 0);
  for (int f : which) {
    const int spot = spot_of[static_cast<std::size_t>(f)];
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
    if (spot_of[static_cast<std::size_t>(f)] >= 0) {
      x(fi) = p.phi;
    } else {
      x(fi) = p.x;
      x(fi + 1) = p.y;
      x(fi + 2) = p.phi;
    }
  }
}

// The offset is fitted when frames at one spot turned far enough to tell it from the pose.
void Solver::decideOffset() {
  fit_offset = false;
  for (const std::vector<int>& g : groups) {
    if (spot_of[static_cast<std::size_t>(g[0])] < 0 || g.size() < 2) continue;
    std::vector<double> hs;
    for (int m : g)
      hs.push_back(start[static_cast<std::size_t>(m)].phi);
    if (headingSpread(hs) >= kPi / 3) fit_offset = true;
  }
  // A known pose pins the robot's centre: the offset follows from the lines.
  for (const UnposedFrame& f : frames) {
    if (f.pose) fit_offset = true;
  }
  if (params.offset == OffsetMode::kZero) fit_offset = false;
  if (params.offset == OffsetMode::kFit && !fit_offset) {
    throw Refusal(
        "--offset fit: the axis offset cannot be told from the robot's position unless frames "
        "were taken at one spot turning (give them with --spot, headings at least 60 degrees "
        "apart)");
  }
}

MonotoneCurve Solver::curve(const Eigen::VectorXd& v) const {
  return curveOf(kr,
                 std::vector<double>(v.data() + kFirstKnot, v.data() + kFirstKnot + layout.knots));
}

bool Solver::knotsValid(const Eigen::VectorXd& v) const {
  for (int k = 0; k < layout.knots; ++k) {
    if (!(v(layout.knot(k)) > (k == 0 ? 0.0 : v(layout.knot(k - 1)) * 1.001 + 1e-4))) {
      return false;
    }
  }
  return true;
}

// Smoothness: the log of the metres per pixel changes steadily from knot to knot (a kink costs
// what a pixel of misfit costs, per `smoothness` of its second difference).
void Solver::smoothness(const double* d, Eigen::VectorXd& res, Eigen::Index at) const {
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
    res(at + layout.knots - 2 + k) = std::log(std::max(1e-9, d[k]) / knot_start(k)) / 0.4;
  }
}

Vec2 Solver::fieldPoint(const Eigen::VectorXd& v, const MonotoneCurve& c, const LinePx& p,
                        const Vec2& ctr) const {
  const double r = tiltedRadius(v, p.pixel, ctr);
  const double b = axisBearing(p.pixel, ctr, base.heading_angle, base.mirrored);
  const double d = c(r);
  const Vec2 robot = Vec2(v(2), v(3)) + d * Vec2(std::cos(b), std::sin(b));
  return geometry::pointRobotToField(poseOf(v, layout, p.frame), robot);
}

int Solver::associate(const Eigen::VectorXd& v, const FitRound& round) {
  const MonotoneCurve c = curve(v);
  const Vec2 ctr(v(0), v(1));
  int count = 0;
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
    count += p.use ? 1 : 0;
  }
  max_distance = round.max_distance_m;
  return count;
}

bool Solver::residuals(const Eigen::VectorXd& v, Eigen::VectorXd& res) const {
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
}

ResidualFunction Solver::residualFunction() const {
  return [this](const Eigen::VectorXd& v, Eigen::VectorXd& res) { return residuals(v, res); };
}

void Solver::setSteps(bool offset, bool tilt) {
  std::fill(steps.begin(), steps.end(), 1e-4);
  steps[2] = steps[3] = offset ? 1e-5 : 0.0;
  steps[4] = steps[5] = tilt ? 1e-4 : 0.0;
  for (int f = 0; f < nf; ++f) {
    // A known pose stays as given; an inactive frame's pose waits.
    if (!frames[static_cast<std::size_t>(f)].pose && active[static_cast<std::size_t>(f)]) {
      continue;
    }
    const int fi = layout.frame_index[static_cast<std::size_t>(f)];
    const int own = spot_of[static_cast<std::size_t>(f)] >= 0 ? 1 : 3;
    for (int k = 0; k < own; ++k)
      steps[static_cast<std::size_t>(fi + k)] = 0.0;
  }
  for (int sp = 0; sp < nspots; ++sp) {
    bool any = false;
    for (int f = 0; f < nf; ++f) {
      any = any ||
            (spot_of[static_cast<std::size_t>(f)] == sp && active[static_cast<std::size_t>(f)]);
    }
    if (!any) {
      steps[static_cast<std::size_t>(layout.spot_index[static_cast<std::size_t>(sp)])] = 0.0;
      steps[static_cast<std::size_t>(layout.spot_index[static_cast<std::size_t>(sp)]) + 1] = 0.0;
    }
  }
}

void Solver::runRounds(std::size_t from) {
  for (std::size_t round = from; round < params.rounds.size(); ++round) {
    // The offset joins once the near field has settled the poses.
    setSteps(fit_offset && round >= 2, round >= 2);
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
    x = levenbergMarquardt(x, residualFunction(), steps, params.huber_px, params.iterations);
  }
}

double Solver::shareOnLines() const {
  const MonotoneCurve c = curve(x);
  const Vec2 ctr(x(0), x(1));
  int inRange = 0;
  for (const LinePx& p : pixels) {
    if (!active[static_cast<std::size_t>(p.frame)]) continue;
    const double d = c(tiltedRadius(x, p.pixel, ctr));
    if (d > 0.15 && d <= max_distance) ++inRange;
  }
  return inRange > 0 ? static_cast<double>(used) / inRange : 0.0;
}

// The seed: frames with known poses, else the group (a spot, or a frame) whose own fit puts
// the largest share of its ridge pixels on the lines (of the three the search placed best).
void Solver::fitJointly() {
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
  placeWaitingFrames();
  repairHeadings();
  for (int f = 0; f < nf; ++f) {
    if (!active[static_cast<std::size_t>(f)]) {
      throw Refusal(frames[static_cast<std::size_t>(f)].name +
                    ": no pose on the field fits its line pixels");
    }
  }
  used = associate(x, params.rounds.back());
}

// A frame's line pixels as robot-frame points under the current state (at most `limit`,
// evenly spread).
std::vector<Vec2> Solver::robotPoints(int f, std::size_t limit) const {
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
  return evenlySpread(finitePoints(pts, non_finite_points), limit);
}

// A frame turned on a spot: its heading scanned at the spot's position (1 degree steps).
double Solver::headingAt(int f, const Vec2& at) const {
  const std::vector<Vec2> pts = robotPoints(f, 400);
  if (!at.allFinite()) return 0.0;  // nowhere to scan from (poseCost would refuse every phi)
  double bestCost = 2.0, bestPhi = 0.0;
  for (int deg = 0; deg < 360; ++deg) {
    const double phi = deg * kPi / 180.0;
    const double c = poseCost(pts, Pose2{at.x(), at.y(), phi}, *grid, 0.15);
    if (c < bestCost) {
      bestCost = c;
      bestPhi = phi;
    }
  }
  return geometry::normalizeAngle(bestPhi);
}

// The frames left out (their place was ambiguous under the search's rough mirror): their poses
// searched again with the fitted mirror and every line pixel up to its range, then all frames
// fitted together.
void Solver::placeWaitingFrames() {
  std::vector<int> waiting;
  for (int f = 0; f < nf; ++f) {
    if (!active[static_cast<std::size_t>(f)]) waiting.push_back(f);
  }
  if (!waiting.empty()) {
    std::vector<std::vector<ScoredPose>> found(static_cast<std::size_t>(nf));
    for (int f : waiting) {
      found[static_cast<std::size_t>(f)] =
          placeFrame(robotPoints(f, 100000), *raster, *grid, field, params, 4);
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
}

// A frame at a spot that still fits badly (its own candidates misled the linking): its heading
// scanned again at the spot's fitted position, and the last rounds run again.
void Solver::repairHeadings() {
  used = associate(x, params.rounds.back());
  std::vector<int> inRange(static_cast<std::size_t>(nf), 0),
      onLine(static_cast<std::size_t>(nf), 0);
  const MonotoneCurve c = curve(x);
  const Vec2 ctr(x(0), x(1));
  for (const LinePx& p : pixels) {
    const double d = c(tiltedRadius(x, p.pixel, ctr));
    if (!(d > 0.15) || d > max_distance) continue;
    ++inRange[static_cast<std::size_t>(p.frame)];
    onLine[static_cast<std::size_t>(p.frame)] += p.use ? 1 : 0;
  }
  bool repaired = false;
  for (int f = 0; f < nf; ++f) {
    const int spot = spot_of[static_cast<std::size_t>(f)];
    if (spot < 0 || frames[static_cast<std::size_t>(f)].pose) continue;
    if (onLine[static_cast<std::size_t>(f)] >= 0.45 * inRange[static_cast<std::size_t>(f)])
      continue;
    const int si = layout.spot_index[static_cast<std::size_t>(spot)];
    x(layout.frame_index[static_cast<std::size_t>(f)]) = headingAt(f, Vec2(x(si), x(si + 1)));
    repaired = true;
  }
  if (repaired) runRounds(params.rounds.size() >= 3 ? params.rounds.size() - 3 : 0);
}

}  // namespace fieldline::calibration::posefree
