#include "services/feature_recognition/pose_hypotheses.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace fieldline::feature_recognition {

double qualityMeasure(int dimension, int quantity) {
  return std::min(1.0, 2.0 / ((1.0 + dimension) * std::max(quantity, 1)));
}

std::vector<Pose2> centreCircleMarks() {
  return {{0.0, 0.0, std::numbers::pi / 2}, {0.0, 0.0, -std::numbers::pi / 2}};
}

std::vector<Pose2> penaltyCornerMarks(const field::FieldModel& field, bool left, bool inner) {
  const auto& d = field.dimensions();
  const double x = field.length() / 2 - (inner ? d.goal_area_depth : d.penalty_area_depth);
  const double y = (inner ? d.goal_area_width : d.penalty_area_width) / 2 * (left ? 1.0 : -1.0);
  // The opponent goal lies toward +x (left = +y); the own goal is its point reflection.
  return {{x, y, 0.0}, {-x, -y, std::numbers::pi}};
}

Pose2 robotPoseFrom(const Pose2& mark, const Pose2& local) {
  Pose2 robot = geometry::compose(mark, geometry::inverse(local));
  robot.phi = geometry::normalizeAngle(robot.phi);
  return robot;
}

void addHypotheses(int feature, const Pose2& local, const std::vector<Pose2>& marks,
                   double sigma_position, double sigma_direction, double min_sigma_xy,
                   double min_sigma_phi, std::vector<perception::PoseHypothesis>& out) {
  // A direction error turns the robot about the feature: its position moves by distance * angle.
  const double distance = std::hypot(local.x, local.y);
  const double sigma_xy =
      std::max(std::hypot(sigma_position, distance * sigma_direction), min_sigma_xy);
  const double sigma_phi = std::max(sigma_direction, min_sigma_phi);
  for (const Pose2& mark : marks) {
    out.push_back({feature, robotPoseFrom(mark, local), sigma_xy, sigma_phi});
  }
}

void rankHypotheses(perception::FieldFeatures& features) {
  std::stable_sort(features.hypotheses.begin(), features.hypotheses.end(),
                   [&](const perception::PoseHypothesis& a, const perception::PoseHypothesis& b) {
                     const double qa = features.features[a.feature].quality;
                     const double qb = features.features[b.feature].quality;
                     if (qa != qb) return qa > qb;
                     return a.sigma_xy < b.sigma_xy;
                   });
}

}  // namespace fieldline::feature_recognition
