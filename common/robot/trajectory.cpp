#include "common/robot/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

namespace fieldline::robot {
namespace {

using geometry::Vec2;

constexpr int kArcTableSize = 4096;
// Random play is planned this far ahead; it repeats afterwards.
constexpr double kRandomPlayHorizon = 3600.0;

// Lemniscate of Gerono with half extents a, b in its own frame: (a sin s, b sin 2s).
Vec2 lemniscate(double a, double b, double s) {
  return {a * std::sin(s), b * std::sin(2.0 * s)};
}
Vec2 lemniscateD1(double a, double b, double s) {
  return {a * std::cos(s), 2.0 * b * std::cos(2.0 * s)};
}
Vec2 lemniscateD2(double a, double b, double s) {
  return {-a * std::sin(s), -4.0 * b * std::sin(2.0 * s)};
}

}  // namespace

Trajectory::Trajectory(const TrajectorySpec& spec, const geometry::Pose2& start)
    : spec_(spec), start_(start) {
  if (const auto* f = std::get_if<FigureEightSpec>(&spec_)) {
    if (!(f->length > 0.0) || !(f->width > 0.0) || !(f->speed >= 0.0)) {
      throw std::invalid_argument("figure eight: length and width must be positive");
    }
    // Arc length over the parameter by the trapezoid rule, then inverted on an even grid.
    const int n = kArcTableSize;
    const double a = f->length / 2.0;
    const double b = f->width / 2.0;
    std::vector<double> cumulative(n + 1, 0.0);
    const double ds = 2.0 * std::numbers::pi / n;
    for (int i = 1; i <= n; ++i) {
      const double s0 = (i - 1) * ds;
      const double s1 = i * ds;
      cumulative[i] = cumulative[i - 1] +
                      0.5 * ds * (lemniscateD1(a, b, s0).norm() + lemniscateD1(a, b, s1).norm());
    }
    perimeter_ = cumulative[n];
    arc_parameter_.resize(n + 1);
    int j = 0;
    for (int k = 0; k <= n; ++k) {
      const double target = perimeter_ * k / n;
      while (j < n - 1 && cumulative[j + 1] < target)
        ++j;
      const double span = cumulative[j + 1] - cumulative[j];
      const double frac = span > 0.0 ? (target - cumulative[j]) / span : 0.0;
      arc_parameter_[k] = (j + std::clamp(frac, 0.0, 1.0)) * ds;
    }
  } else if (const auto* w = std::get_if<WaypointSpec>(&spec_)) {
    if (w->points.empty()) throw std::invalid_argument("waypoint tour: no points");
    if (!(w->speed > 0.0)) throw std::invalid_argument("waypoint tour: speed must be positive");
    face_along_path_ = w->face_along_path;
    buildLegs(w->points, w->speed, w->loop);
  } else if (const auto* r = std::get_if<RandomPlaySpec>(&spec_)) {
    if (!(r->speed > 0.0)) throw std::invalid_argument("random play: speed must be positive");
    std::mt19937_64 rng(r->seed);
    std::uniform_real_distribution<double> ux(-r->half_length, r->half_length);
    std::uniform_real_distribution<double> uy(-r->half_width, r->half_width);
    std::vector<Vec2> points;
    double travelled = 0.0;
    Vec2 last = start_.position();
    while (travelled < kRandomPlayHorizon * r->speed) {
      const Vec2 p(ux(rng), uy(rng));
      travelled += (p - last).norm();
      points.push_back(p);
      last = p;
    }
    buildLegs(points, r->speed, false);
  }
}

void Trajectory::buildLegs(const std::vector<Vec2>& points, double speed, bool loop) {
  Vec2 from = start_.position();
  double t = 0.0;
  auto add = [&](const Vec2& to) {
    const double duration = (to - from).norm() / speed;
    if (duration > 0.0) {
      legs_.push_back({from, to, t, duration});
      t += duration;
    }
    from = to;
  };
  for (const auto& p : points)
    add(p);
  if (loop && points.size() > 1) {
    // The loop runs from the first point around and back to it; the approach leg is not repeated.
    const double approach = (points.front() - start_.position()).norm() / speed;
    add(points.front());
    loop_period_ = t - approach;
  }
}

TrajectorySample Trajectory::at(double t) const {
  t = std::max(t, 0.0);
  return std::visit(
      [&](const auto& spec) -> TrajectorySample {
        using S = std::decay_t<decltype(spec)>;
        if constexpr (std::is_same_v<S, FigureEightSpec>) {
          return figureEightAt(t);
        } else if constexpr (std::is_same_v<S, RotateSpec>) {
          return {{start_.x, start_.y, geometry::normalizeAngle(start_.phi + spec.omega * t)},
                  Vec2::Zero(),
                  spec.omega};
        } else if constexpr (std::is_same_v<S, StandSpec>) {
          return {start_, Vec2::Zero(), 0.0};
        } else {
          return legsAt(t);
        }
      },
      spec_);
}

TrajectorySample Trajectory::figureEightAt(double t) const {
  const auto& f = std::get<FigureEightSpec>(spec_);
  const double a = f.length / 2.0;
  const double b = f.width / 2.0;
  const double distance = std::fmod(f.speed * t, perimeter_);
  const double pos = distance / perimeter_ * kArcTableSize;
  const int k = std::min(static_cast<int>(pos), kArcTableSize - 1);
  const double s = arc_parameter_[k] + (pos - k) * (arc_parameter_[k + 1] - arc_parameter_[k]);
  const Vec2 d1 = lemniscateD1(a, b, s);
  const Vec2 d2 = lemniscateD2(a, b, s);
  const Vec2 p = geometry::rotate(lemniscate(a, b, s), f.rotation) + f.center;
  const Vec2 tangent = geometry::rotate(d1.normalized(), f.rotation);
  const double curvature = (d1.x() * d2.y() - d1.y() * d2.x()) / std::pow(d1.norm(), 3);
  TrajectorySample out;
  out.pose = {p.x(), p.y(), std::atan2(tangent.y(), tangent.x())};
  out.velocity = tangent * f.speed;
  out.omega = curvature * f.speed;
  return out;
}

TrajectorySample Trajectory::legsAt(double t) const {
  if (legs_.empty()) return {start_, Vec2::Zero(), 0.0};
  const double total = legs_.back().t0 + legs_.back().duration;
  if (t >= total) {
    if (loop_period_ <= 0.0) {
      const Leg& last = legs_.back();
      const Vec2 dir = (last.to - last.from).normalized();
      const double phi = face_along_path_ ? std::atan2(dir.y(), dir.x()) : start_.phi;
      return {{last.to.x(), last.to.y(), phi}, Vec2::Zero(), 0.0};
    }
    t = total - loop_period_ + std::fmod(t - total, loop_period_);
  }
  // Legs are sorted by start time.
  const auto it = std::upper_bound(legs_.begin(), legs_.end(), t,
                                   [](double value, const Leg& leg) { return value < leg.t0; });
  const Leg& leg = *std::prev(it);
  const double frac = std::clamp((t - leg.t0) / leg.duration, 0.0, 1.0);
  const Vec2 dir = (leg.to - leg.from) / (leg.to - leg.from).norm();
  const Vec2 p = leg.from + frac * (leg.to - leg.from);
  const double speed = (leg.to - leg.from).norm() / leg.duration;
  const double phi = face_along_path_ ? std::atan2(dir.y(), dir.x()) : start_.phi;
  return {{p.x(), p.y(), phi}, dir * speed, 0.0};
}

NormalizedCommand followTrajectory(const TrajectorySample& reference,
                                   const geometry::Pose2& measured, const RobotParams& params,
                                   const FollowerGains& gains) {
  Vec2 correction = gains.position_gain * (reference.pose.position() - measured.position());
  if (correction.norm() > gains.max_correction_speed) {
    correction *= gains.max_correction_speed / correction.norm();
  }
  const Vec2 field_velocity = reference.velocity + correction;
  const Vec2 body = geometry::vectorFieldToRobot(measured, field_velocity);
  const double omega =
      reference.omega + gains.heading_gain * geometry::angleDiff(reference.pose.phi, measured.phi);
  NormalizedCommand cmd{body.x() / params.max_speed, body.y() / params.max_speed,
                        omega / params.max_omega};
  // Keep the direction when the translation asks for more than full speed.
  const double translation = std::hypot(cmd.vx, cmd.vy);
  if (translation > 1.0) {
    cmd.vx /= translation;
    cmd.vy /= translation;
  }
  cmd.omega = std::clamp(cmd.omega, -1.0, 1.0);
  return cmd;
}

}  // namespace fieldline::robot
