// Synthetic line points for the feature recognition tests: polylines and circles with noise, and
// whole frames sampled from the field model's lines as a robot at a given pose would see them.
#pragma once

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/line_points.hpp"
#include "services/feature_recognition/contour_preparation.hpp"

namespace fieldline::feature_recognition::test {

using geometry::Vec2;

// Prepared contours with one piece per run of points, for the stages after splitting.
inline Contours contoursOf(const std::vector<std::vector<Vec2>>& runs) {
  Contours c;
  for (const auto& run : runs) {
    const int begin = static_cast<int>(c.points.size());
    c.points.insert(c.points.end(), run.begin(), run.end());
    c.pieces.push_back({begin, static_cast<int>(c.points.size())});
  }
  return c;
}

// Appends one sequence to `out`.
inline void addSequence(perception::LinePoints& out, const std::vector<Vec2>& points) {
  const int start = static_cast<int>(out.points.size());
  for (const Vec2& p : points) {
    out.points.push_back({0, 0, static_cast<float>(p.x()), static_cast<float>(p.y())});
  }
  out.sequences.emplace_back(start, static_cast<int>(out.points.size()));
}

// Points every `step` along the polyline through `corners`, with Gaussian noise `sigma`.
inline std::vector<Vec2> polyline(const std::vector<Vec2>& corners, double step, double sigma,
                                  std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Vec2> out;
  for (std::size_t i = 1; i < corners.size(); ++i) {
    const Vec2 a = corners[i - 1], b = corners[i];
    const int n = std::max(1, static_cast<int>(std::round((b - a).norm() / step)));
    for (int k = (i == 1 ? 0 : 1); k <= n; ++k) {
      out.push_back(a + (b - a) * k / n + Vec2(noise(rng), noise(rng)));
    }
  }
  return out;
}

// Points every `step` along the circle from angle `from` to `to` (rad, CCW).
inline std::vector<Vec2> arc(const Vec2& centre, double radius, double from, double to, double step,
                             double sigma, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Vec2> out;
  const int n = std::max(2, static_cast<int>(std::round(radius * (to - from) / step)));
  for (int k = 0; k <= n; ++k) {
    const double a = from + (to - from) * k / n;
    out.push_back(centre + radius * Vec2(std::cos(a), std::sin(a)) + Vec2(noise(rng), noise(rng)));
  }
  return out;
}

// The field's lines as a robot at `pose` sees them up to `range` (m): each segment and arc
// sampled every `step`, cut where it leaves the range, in the robot frame, with noise.
inline perception::LinePoints frameAt(const field::FieldModel& field, const geometry::Pose2& pose,
                                      double range, double step, double sigma,
                                      std::uint32_t seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  perception::LinePoints out;
  std::vector<Vec2> run;
  auto flush = [&] {
    if (run.size() >= 5) addSequence(out, run);
    run.clear();
  };
  auto visit = [&](const Vec2& p) {
    const Vec2 local = geometry::pointFieldToRobot(pose, p);
    if (local.norm() > range || local.norm() < 0.4) {
      flush();
      return;
    }
    run.push_back(local + Vec2(noise(rng), noise(rng)));
  };
  for (const auto& s : field.segments()) {
    const int n = static_cast<int>(std::ceil(s.length() / step));
    for (int k = 0; k <= n; ++k)
      visit(s.a + (s.b - s.a) * k / n);
    flush();
  }
  for (const auto& a : field.arcs()) {
    const int n = static_cast<int>(std::ceil(a.radius * a.sweep / step));
    for (int k = 0; k <= n; ++k)
      visit(a.pointAt(a.start_angle + a.sweep * k / n));
    flush();
  }
  return out;
}

}  // namespace fieldline::feature_recognition::test
