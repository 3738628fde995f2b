// Stage 7 (seed 4.13, "Quality and Quantity of Features", "Direct Pose Inference by High-Level
// Features"): each feature's reference mark, seen at a local pose q in the robot frame, is matched
// to every pose p of that mark in the field model; the robot is then at p * inverse(q). The field
// is point-symmetric, so each high-level feature has two such poses (quantity 2, quality 0).
#pragma once

#include <vector>

#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/field_features.hpp"

namespace fieldline::feature_recognition {

using geometry::Pose2;

// The seed's quality/quantity measure of a feature type as a number in (0, 1]: the dimension of
// the poses one feature leaves open and how many separate sets of them the field has. 1 for the
// high-level features (dimension 0, quantity 2), less for everything lower in the hierarchy.
double qualityMeasure(int dimension, int quantity);

// Field poses of the centre circle's reference mark: at the centre spot, its direction along the
// halfway line (both ways).
std::vector<Pose2> centreCircleMarks();
// Field poses of a penalty-area corner: its direction toward the goal. One per goal.
std::vector<Pose2> penaltyCornerMarks(const field::FieldModel& field, bool left, bool inner);

// The robot's field pose when the mark at field pose `mark` is seen at `local` (robot frame).
Pose2 robotPoseFrom(const Pose2& mark, const Pose2& local);

// Appends one hypothesis per mark for feature `feature` seen at `local`, with the standard
// deviations of the feature's position (sigma_position, m) and direction (sigma_direction, rad)
// carried to the robot's pose, floored at min_sigma_xy and min_sigma_phi.
void addHypotheses(int feature, const Pose2& local, const std::vector<Pose2>& marks,
                   double sigma_position, double sigma_direction, double min_sigma_xy,
                   double min_sigma_phi, std::vector<perception::PoseHypothesis>& out);

// Orders hypotheses best first: by their feature's quality, then by sigma_xy.
void rankHypotheses(perception::FieldFeatures& features);

}  // namespace fieldline::feature_recognition
