// A field and robot for fusion tests: line points rendered from the field model as a robot at
// a pose would see them, and a slow but exact stand-in for layer 2 (pattern search on the field's
// true distance) so the localizer and the node are tested without the distance-grid matcher.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <span>
#include <vector>

#include "common/field/field_model.hpp"
#include "common/robot/robot_params.hpp"
#include "services/fusion/localizer.hpp"

namespace fieldline::fusion::test_support {

struct TestWorld {
  field::FieldModel field = field::loadFieldPreset("msl");
  robot::RobotParams robot = robot::loadRobotPreset("fu2004");
  std::vector<geometry::Vec2> line_points;

  TestWorld() {
    for (const auto& s : field.segments()) {
      const int n = static_cast<int>(s.length() / 0.1);
      for (int i = 0; i <= n; ++i)
        line_points.push_back(s.a + (s.b - s.a) * (static_cast<double>(i) / std::max(n, 1)));
    }
    for (const auto& a : field.arcs()) {
      const int n = static_cast<int>(std::abs(a.sweep) * a.radius / 0.1);
      for (int i = 0; i <= n; ++i)
        line_points.push_back(a.pointAt(a.start_angle + a.sweep * i / std::max(n, 1)));
    }
  }

  // The field-line points within 4 m, in the robot frame, with 1 cm noise.
  std::vector<perception::LinePoint> view(const geometry::Pose2& pose, std::mt19937& rng) const {
    std::normal_distribution<double> noise(0.0, 0.01);
    std::vector<perception::LinePoint> out;
    for (const auto& p : line_points) {
      const geometry::Vec2 local = geometry::pointFieldToRobot(pose, p);
      if (local.norm() > 4.0 || local.norm() < 0.3) continue;
      perception::LinePoint lp;
      lp.x = static_cast<float>(local.x() + noise(rng));
      lp.y = static_cast<float>(local.y() + noise(rng));
      out.push_back(lp);
    }
    return out;
  }

  double cost(std::span<const perception::LinePoint> points, const geometry::Pose2& pose) const {
    if (points.empty()) return 0.5;
    double sum = 0.0;
    for (const auto& lp : points) {
      const geometry::Vec2 f = geometry::pointRobotToField(pose, {lp.x, lp.y});
      sum += std::min(field.distance(f), 0.5);
    }
    return sum / static_cast<double>(points.size());
  }

  PoseCorrection correct(std::span<const perception::LinePoint> points,
                         const geometry::Pose2& guess) const {
    PoseCorrection c;
    c.points_used = static_cast<int>(points.size());
    if (points.size() < 10) return c;
    // Pattern search: good enough for a test, far too slow for a robot.
    geometry::Pose2 best = guess;
    double best_cost = cost(points, best);
    for (double step = 0.2; step > 0.004; step *= 0.5) {
      bool improved = true;
      while (improved) {
        improved = false;
        const geometry::Pose2 moves[6] = {{step, 0, 0},  {-step, 0, 0},      {0, step, 0},
                                          {0, -step, 0}, {0, 0, step * 0.5}, {0, 0, -step * 0.5}};
        for (const auto& m : moves) {
          geometry::Pose2 p{best.x + m.x, best.y + m.y, geometry::normalizeAngle(best.phi + m.phi)};
          const double cp = cost(points, p);
          if (cp < best_cost - 1e-9) {
            best = p;
            best_cost = cp;
            improved = true;
          }
        }
      }
    }
    c.valid = true;
    c.pose = best;
    c.cost = best_cost;
    c.covariance = Eigen::Vector3d(0.03 * 0.03, 0.03 * 0.03, 0.02 * 0.02).asDiagonal();
    return c;
  }

  MatcherFunctions functions() const {
    return {[this](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
              return correct(p, g);
            },
            [this](std::span<const perception::LinePoint> p, const geometry::Pose2& g) {
              return cost(p, g);
            }};
  }
};

inline const TestWorld& world() {
  static const TestWorld w;
  return w;
}

}  // namespace fieldline::fusion::test_support
