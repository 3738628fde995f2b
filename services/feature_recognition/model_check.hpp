// The model check (beyond the seed): a feature's pose hypothesis is kept only if the frame's line
// points, moved into the field by that pose, lie on the field model's lines. A feature explains
// its own points by construction; the other lines of the frame (the field's border, the halfway
// line, the other penalty-area lines) tell a true pose from a mirror image or a structure that
// merely looks like the feature. Distances come from a precomputed distance grid of the field
// model, so one check costs one grid lookup per point.
#pragma once

#include <cstdint>
#include <vector>

#include "common/field/distance_grid.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/feature_recognition/params.hpp"

namespace fieldline::feature_recognition {

struct ModelFit {
  // Points within the check's range and those of them within the tolerance of a model line.
  int points = 0;
  int inliers = 0;
  double share() const { return points > 0 ? static_cast<double>(inliers) / points : 0.0; }
};

// A straight piece of a feature, robot frame.
struct Segment2 {
  geometry::Vec2 a = geometry::Vec2::Zero();
  geometry::Vec2 b = geometry::Vec2::Zero();
};

// The points further than `margin` from every segment: the frame's "other" points, those a
// feature does not explain by construction.
void pointsAwayFrom(const std::vector<geometry::Vec2>& points,
                    const std::vector<Segment2>& segments, double margin,
                    std::vector<geometry::Vec2>& out);

class ModelCheck {
 public:
  // Builds the distance grid (a few ms for an msl field). Throws std::invalid_argument for
  // unusable parameters.
  ModelCheck(const field::FieldModel& field, const RecognitionParams& params);

  // How well `points` (robot frame, m) fit the field's lines with the robot at `robot`. With
  // model_check_goal_shadow, points in a goal's shadow are not counted at all.
  ModelFit fit(const std::vector<geometry::Vec2>& points, const geometry::Pose2& robot) const;
  // As fit(), but on at most `max_points` of them (evenly thinned): a cheaper estimate of the
  // share when many poses are compared.
  ModelFit fit(const std::vector<geometry::Vec2>& points, const geometry::Pose2& robot,
               int max_points) const;
  // The shift s (m, |s| <= max_shift) of the robot along the unit vector u (field frame) that
  // best fits the points within the tolerance to the lines: a few Gauss-Newton steps on the
  // squared distances (the distance grid's gradient). Refines a pose whose position along u only
  // the points fix (a corner placed from a line's end).
  double refineShift(const std::vector<geometry::Vec2>& points, const geometry::Pose2& robot,
                     const geometry::Vec2& u, double max_shift) const;
  // True if the fit is good enough to keep the hypothesis.
  bool accepts(const ModelFit& fit) const;
  // True if the fit of all points and that of the other points (see pointsAwayFrom) are good
  // enough: the other points must be enough in number and fit as well.
  bool accepts(const ModelFit& all, const ModelFit& others) const;

 private:
  field::DistanceGrid grid_;
  // The grid's node distances in units of kUnit, saturated at 255 (every tolerance is far below
  // 255 units, and a node beyond it has all its neighbours within one cell beyond the largest
  // tolerance too): a quarter of the float grid's memory, so the lookups stay in the cache.
  static constexpr double kUnit = 0.002;
  std::vector<std::uint8_t> compact_;
  double origin_x_ = 0.0, origin_y_ = 0.0, inverse_cell_ = 1.0;
  int columns_ = 0, rows_ = 0;
  // True when every point outside the compact grid's cells is further from every line than the
  // largest tolerance (the grid's margin minus a cell exceeds it): such points never fit.
  bool outside_never_fits_ = false;
  // True if the field point q (found at `range` from the robot) is within the tolerance of a
  // model line: the bilinear interpolation of the compact grid, the exact grid outside it.
  bool fits(double qx, double qy, double range) const;
  // The goals' footprints (model_check_goal_shadow): mouth centre, unit outward and across,
  // the extent along outward (from the mouth, the goal line's outer edge) and the half width
  // across, grown by the tolerance beyond the back and the sides.
  struct GoalBox {
    double cx, cy, ux, uy, from, to, half_width;
  };
  std::vector<GoalBox> goal_boxes_;
  // A goal box seen from the robot: the robot's position along and across it, and whether the
  // robot is in or at the goal (then it casts no shadow).
  struct GoalView {
    double ar = 0.0, cr = 0.0;
    bool none = true;
  };
  GoalView goalView(const GoalBox& box, double rx, double ry) const;
  // True if the segment from the robot to the field point (qx, qy) crosses the goal box.
  bool inGoalShadow(const GoalBox& box, const GoalView& view, double qx, double qy) const;
  double tolerance_;
  double tolerance_per_m_;
  double range_;
  double min_share_;
  int max_points_;
  int min_other_points_;
  double min_other_share_;
};

}  // namespace fieldline::feature_recognition
