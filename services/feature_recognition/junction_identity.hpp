// Identifying an observed L-corner or T-junction (beyond the seed): the field has many of each,
// so one alone does not fix the pose; but every place it could be gives a candidate pose, and the
// model check on the frame's other points (those not on the junction's own lines) tells them
// apart. A junction is identified only when exactly one candidate, up to the field's point
// symmetry, fits, and the others clearly do not; when too few other points are seen, or two
// places fit, it stays unidentified. An identified L at a penalty-area or goal-area corner is a
// penalty corner even when the rest of the area's lines are too sparse for the structure of stage
// 5 (the usual case from 3-4 m away).
#pragma once

#include <vector>

#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/feature_recognition/junctions.hpp"
#include "services/feature_recognition/model_check.hpp"

namespace fieldline::feature_recognition {

// A junction of the field's lines: where two perpendicular segments meet, with the directions
// (field frame, unit) and lengths of the line pieces leaving it.
struct ModelJunction {
  Vec2 position = Vec2::Zero();
  std::vector<Vec2> legs;
  std::vector<double> leg_lengths;
  // atan2 of each leg (field frame), rad.
  std::vector<double> leg_angles;
  // Set for the corners of the penalty and goal areas (the eight penalty corners).
  bool penalty_corner = false;
  bool inner = false;
  bool left = false;
  // Unit vector toward the area's goal (field frame).
  Vec2 toward_goal = Vec2::UnitX();
};

// Every junction of the field's straight lines.
std::vector<ModelJunction> modelJunctions(const field::FieldModel& field);

struct JunctionIdentity {
  // Index into the model junctions and the robot pose it implies (one of the two symmetric ones).
  int model = -1;
  geometry::Pose2 robot;
  // The model check on the other points: of the chosen candidate and the best rival (a candidate
  // that is not the chosen one or its twin; share 0 if there is none).
  ModelFit fit;
  double rival_share = 0.0;
};

// Identifies `junction` (robot frame, its legs filled in) among `models`; `points` are the
// frame's points (robot frame). False when it stays unidentified.
bool identifyJunction(const Junction& junction, const std::vector<ModelJunction>& models,
                      const std::vector<Vec2>& points, const ModelCheck& check,
                      const RecognitionParams& params, JunctionIdentity& out);

}  // namespace fieldline::feature_recognition
