// High-level field features of one frame and the field poses they imply (FIELD_FEATURES without
// LCM): what feature recognition finds and fusion reads.
#pragma once

#include <cstdint>
#include <vector>

#include "common/geometry/geometry.hpp"

namespace fieldline::perception {

// Values equal field_features_t's KIND_ constants (checked at compile time in common/msg).
enum class FeatureKind : std::int8_t {
  kCentreCircle = 1,
  kPenaltyCorner = 2,
  kFieldCorner = 3,
  kTJunction = 4,
  kStraightLine = 5,
  kGoal = 6,
};

struct FieldFeature {
  FeatureKind kind = FeatureKind::kCentreCircle;
  // Pose of the feature in the robot frame (x forward, y left, phi CCW from x), m and rad.
  geometry::Pose2 local;
  // 0..1, the seed's quality/quantity measure.
  double quality = 0.0;
};

// A robot pose in the field frame consistent with one feature.
struct PoseHypothesis {
  // Index into FieldFeatures::features.
  int feature = 0;
  geometry::Pose2 pose;
  // Standard deviations of the position (m) and heading (rad).
  double sigma_xy = 0.0;
  double sigma_phi = 0.0;
};

struct FieldFeatures {
  std::vector<FieldFeature> features;
  // Ranked best first.
  std::vector<PoseHypothesis> hypotheses;
  void clear() {
    features.clear();
    hypotheses.clear();
  }
};

}  // namespace fieldline::perception
