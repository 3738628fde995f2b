#include "services/feature_recognition/model_check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace fieldline::feature_recognition {

ModelCheck::ModelCheck(const field::FieldModel& field, const RecognitionParams& params)
    : grid_(field, params.model_check_cell, params.model_check_margin),
      tolerance_(params.model_check_tolerance),
      tolerance_per_m_(params.model_check_tolerance_per_m),
      range_(params.model_check_range),
      min_share_(params.model_check_min_share),
      max_points_(params.model_check_max_points),
      min_other_points_(params.model_check_min_other_points),
      min_other_share_(params.model_check_min_other_share) {
  if (!(tolerance_ > 0.0) || !(tolerance_per_m_ >= 0.0) || !(range_ > 0.0) ||
      !(min_share_ >= 0.0 && min_share_ <= 1.0) || max_points_ < 1 || min_other_points_ < 0 ||
      !(min_other_share_ >= 0.0 && min_other_share_ <= 1.0)) {
    throw std::invalid_argument(
        "ModelCheck: tolerance and range must be positive, shares in [0, 1], max_points >= 1, "
        "min_other_points >= 0");
  }
  if (params.model_check_goal_shadow) {
    for (const field::Goal& g : field.goals()) {
      goal_boxes_.push_back({g.mouth_centre.x(), g.mouth_centre.y(), g.outward.x(), g.outward.y(),
                             0.0, g.depth + tolerance_, g.width / 2 + tolerance_});
    }
  }
  columns_ = grid_.columns();
  rows_ = grid_.rows();
  origin_x_ = grid_.origin().x();
  origin_y_ = grid_.origin().y();
  inverse_cell_ = 1.0 / grid_.cellSize();
  outside_never_fits_ =
      params.model_check_margin - 2.0 * grid_.cellSize() > tolerance_ + tolerance_per_m_ * range_;
  compact_.resize(static_cast<std::size_t>(columns_) * static_cast<std::size_t>(rows_));
  for (int j = 0; j < rows_; ++j) {
    for (int i = 0; i < columns_; ++i) {
      const double units = std::round(grid_.nodeValue(i, j) / kUnit);
      compact_[static_cast<std::size_t>(j) * columns_ + i] =
          static_cast<std::uint8_t>(std::min(units, 255.0));
    }
  }
}

bool ModelCheck::fits(double qx, double qy, double range) const {
  const double limit = tolerance_ + tolerance_per_m_ * range;
  const double gx = (qx - origin_x_) * inverse_cell_;
  const double gy = (qy - origin_y_) * inverse_cell_;
  // Outside the compact grid's cells (or not finite): the exact grid with its extension.
  if (!(gx >= 0.0 && gy >= 0.0 && gx < columns_ - 1 && gy < rows_ - 1)) {
    if (outside_never_fits_ && std::isfinite(gx) && std::isfinite(gy)) return false;
    return grid_.distance(geometry::Vec2(qx, qy)) <= limit;
  }
  const int i = static_cast<int>(gx), j = static_cast<int>(gy);
  const double fx = gx - i, fy = gy - j;
  const std::uint8_t* row = compact_.data() + static_cast<std::size_t>(j) * columns_ + i;
  const double v00 = row[0], v10 = row[1], v01 = row[columns_], v11 = row[columns_ + 1];
  const double units =
      (1.0 - fy) * ((1.0 - fx) * v00 + fx * v10) + fy * ((1.0 - fx) * v01 + fx * v11);
  return units * kUnit <= limit;
}

ModelCheck::GoalView ModelCheck::goalView(const GoalBox& b, double rx, double ry) const {
  GoalView v;
  v.ar = (rx - b.cx) * b.ux + (ry - b.cy) * b.uy;
  v.cr = -(rx - b.cx) * b.uy + (ry - b.cy) * b.ux;
  // A robot in the goal (or at its mouth) sees the goal's parts all around: no shadow.
  v.none = v.ar >= b.from - tolerance_ && std::abs(v.cr) <= b.half_width;
  return v;
}

bool ModelCheck::inGoalShadow(const GoalBox& b, const GoalView& v, double qx, double qy) const {
  if (v.none) return false;
  // Along (a) and across (c) the goal, from its mouth centre.
  const double aq = (qx - b.cx) * b.ux + (qy - b.cy) * b.uy;
  if (std::max(v.ar, aq) < b.from) return false;  // both in front of the goal: the usual case
  const double cq = -(qx - b.cx) * b.uy + (qy - b.cy) * b.ux;
  // The segment r + t (q - r), t in [0, 1], against the slabs of the box.
  double t0 = 0.0, t1 = 1.0;
  auto clip = [&](double p, double d, double lo, double hi) {
    if (std::abs(d) < 1e-12) return p >= lo && p <= hi;
    double ta = (lo - p) / d, tb = (hi - p) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    return t0 <= t1;
  };
  return clip(v.ar, aq - v.ar, b.from, b.to) && clip(v.cr, cq - v.cr, -b.half_width, b.half_width);
}

ModelFit ModelCheck::fit(const std::vector<geometry::Vec2>& points,
                         const geometry::Pose2& robot) const {
  return fit(points, robot, max_points_);
}

ModelFit ModelCheck::fit(const std::vector<geometry::Vec2>& points, const geometry::Pose2& robot,
                         int max_points) const {
  ModelFit out;
  // Bounded time: at most max_points points, spread evenly over the frame.
  const std::size_t n = points.size();
  const std::size_t limit = static_cast<std::size_t>(std::clamp(max_points, 1, max_points_));
  const std::size_t step = std::max<std::size_t>(1, (n + limit - 1) / limit);
  const double c = std::cos(robot.phi), s = std::sin(robot.phi);
  // The goals as seen from the robot (model_check_goal_shadow; the field has at most two).
  // Only goals whose mouth is within the check's range can shadow a point.
  std::array<GoalView, 2> views;
  std::array<const GoalBox*, 2> boxes{};
  std::size_t goals = 0;
  for (const GoalBox& b : goal_boxes_) {
    const GoalView v = goalView(b, robot.x, robot.y);
    if (v.none || b.from - v.ar > range_ || goals == views.size()) continue;
    views[goals] = v;
    boxes[goals++] = &b;
  }
  for (std::size_t i = 0; i < n; i += step) {
    const geometry::Vec2& p = points[i];
    const double range = p.norm();
    if (!(range <= range_)) continue;
    const geometry::Vec2 q(robot.x + c * p.x() - s * p.y(), robot.y + s * p.x() + c * p.y());
    bool shadowed = false;
    for (std::size_t g = 0; g < goals && !shadowed; ++g) {
      const GoalBox& b = *boxes[g];
      // The cheap part inline: both the robot and the point in front of the goal's mouth.
      if (views[g].ar < b.from && (q.x() - b.cx) * b.ux + (q.y() - b.cy) * b.uy < b.from) continue;
      shadowed = inGoalShadow(b, views[g], q.x(), q.y());
    }
    if (shadowed) continue;
    ++out.points;
    if (fits(q.x(), q.y(), range)) ++out.inliers;
  }
  return out;
}

double ModelCheck::refineShift(const std::vector<geometry::Vec2>& points,
                               const geometry::Pose2& robot, const geometry::Vec2& u,
                               double max_shift) const {
  const double c = std::cos(robot.phi), s = std::sin(robot.phi);
  double shift = 0.0;
  for (int iteration = 0; iteration < 4; ++iteration) {
    const geometry::Vec2 origin = robot.position() + shift * u;
    double num = 0.0, den = 0.0;
    for (const geometry::Vec2& p : points) {
      const double range = p.norm();
      if (!(range <= range_)) continue;
      const geometry::Vec2 q(origin.x() + c * p.x() - s * p.y(),
                             origin.y() + s * p.x() + c * p.y());
      const double d = grid_.distance(q);
      if (d > tolerance_ + tolerance_per_m_ * range) continue;
      const double j = grid_.gradient(q).dot(u);
      num += d * j;
      den += j * j;
    }
    if (!(den > 1e-9)) break;
    shift = std::clamp(shift - num / den, -max_shift, max_shift);
  }
  return shift;
}

bool ModelCheck::accepts(const ModelFit& fit) const {
  return fit.share() >= min_share_;
}

bool ModelCheck::accepts(const ModelFit& all, const ModelFit& others) const {
  return accepts(all) && others.points >= min_other_points_ && others.share() >= min_other_share_;
}

void pointsAwayFrom(const std::vector<geometry::Vec2>& points,
                    const std::vector<Segment2>& segments, double margin,
                    std::vector<geometry::Vec2>& out) {
  out.clear();
  for (const geometry::Vec2& p : points) {
    bool near = false;
    for (const Segment2& s : segments) {
      const geometry::Vec2 d = s.b - s.a;
      const double len2 = d.squaredNorm();
      const double t = len2 > 0.0 ? std::clamp((p - s.a).dot(d) / len2, 0.0, 1.0) : 0.0;
      if ((p - (s.a + t * d)).norm() < margin) {
        near = true;
        break;
      }
    }
    if (!near) out.push_back(p);
  }
}

}  // namespace fieldline::feature_recognition
