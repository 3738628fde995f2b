// Feature recognition (seed 4.13, layer 3 of the localization): one frame's line points in, the
// high-level features (centre circle, the four kinds of penalty-area corner) and lower ones
// (L-corners, T-junctions, straight lines) out, with every field pose the high-level ones imply.
// Plain library: no bus, no clock. The stages, in the seed's order, each in its own file:
//   contour_preparation  smoothing, curvature, splitting
//   classification       straight or curved, arcs and lines
//   centre_circle        arc clustering, re-classification, Landau fit, orientation line
//   line_structure       principal directions, collinear groups in topological order
//   penalty_area         goal line / goal-area line / penalty-area line and their corners
//   junctions            L-corners, T-junctions (beyond the seed)
//   pose_hypotheses      reference marks, symmetric poses, ranking
//   model_check          a high-level feature is kept only if the frame's points fit the field
//                        model at the pose it implies (beyond the seed)
//   junction_identity    L-corners placed on the field by the model check: penalty corners
//                        whose area is too sparse for stage 5 (beyond the seed)
// Not thread-safe: one recogniser per thread.
#pragma once

#include <utility>
#include <vector>

#include "common/field/field_model.hpp"
#include "common/perception/field_features.hpp"
#include "common/perception/line_points.hpp"
#include "services/feature_recognition/centre_circle.hpp"
#include "services/feature_recognition/junction_identity.hpp"
#include "services/feature_recognition/junctions.hpp"
#include "services/feature_recognition/line_end_identity.hpp"
#include "services/feature_recognition/model_check.hpp"
#include "services/feature_recognition/penalty_area.hpp"
#include "services/feature_recognition/unseen_lines.hpp"

namespace fieldline::feature_recognition {

// The model check's verdict on one high-level feature of the last frame.
struct CheckedFeature {
  perception::FeatureKind kind = perception::FeatureKind::kCentreCircle;
  geometry::Pose2 local;
  // The robot pose from the feature's first reference mark.
  geometry::Pose2 robot;
  // The fit of all points and of the other points (not on the feature's own lines; penalty
  // corners only).
  ModelFit fit;
  ModelFit others;
  // L-corners and line ends placed by the model check: the best rival place's share of the
  // other points, and (line ends) the best share with the pose shifted (line_end_identity).
  double rival_share = 0.0;
  double shifted_share = 0.0;
  // Line ends: points on the corner's other line (line_end_identity); line ends and L-corners:
  // points near the corner off its lines (pointsOffJunction). -1 for other features.
  int side_points = -1;
  int beyond_points = -1;
  // The longest stretch of model line (m) the pose puts in clear view near the robot without a
  // point near it (unseen_lines.hpp); 0 when not tested (the check off, or the feature refused
  // before it).
  double unseen = 0.0;
  bool accepted = false;
  // Refused after passing: another high-level feature of the frame fits the points better and
  // implies a different pose (one robot has one pose, up to the field's point symmetry).
  bool inconsistent = false;
};

class FeatureRecognizer {
 public:
  // `field` must outlive the recogniser.
  explicit FeatureRecognizer(const field::FieldModel& field, RecognitionParams params = {});

  // Recognises the features of one frame into `out` (cleared first). Unsound sequences are
  // dropped and reported in the returned check; a frame with too many points yields nothing.
  InputCheck recognize(const perception::LinePoints& in, perception::FieldFeatures& out);

  const RecognitionParams& params() const { return params_; }
  const field::FieldModel& field() const { return field_; }
  // The intermediate results of the last frame (for drawings and tests).
  const Contours& contours() const { return contours_; }
  const Classified& classified() const { return classified_; }
  const CentreCircle& circle() const { return circle_; }
  const LineStructure& structure() const { return structure_; }
  bool penaltyFound() const { return penalty_found_; }
  const PenaltyStructure& penalty() const { return penalty_; }
  const std::vector<Junction>& junctions() const { return junctions_; }
  // Every high-level feature found in the last frame with the model check's verdict.
  const std::vector<CheckedFeature>& checked() const { return checked_; }

 private:
  const field::FieldModel& field_;
  RecognitionParams params_;
  ModelCheck model_check_;
  UnseenLines unseen_;
  std::vector<ModelJunction> model_junctions_;
  // Number of L-corners and T-junctions the field's lines form (quantities of those features).
  int field_corners_ = 12;
  int field_t_junctions_ = 10;
  Contours contours_;
  Classified classified_;
  CentreCircle circle_;
  LineStructure structure_;
  bool penalty_found_ = false;
  PenaltyStructure penalty_;
  std::vector<Junction> junctions_;
  std::vector<CheckedFeature> checked_;

  // Clears the last frame's results and runs the stages on `in` (contours to junctions).
  InputCheck runStages(const perception::LinePoints& in);
  // The high-level features: each adds the feature and its pose hypotheses to `out` when it
  // passes its checks.
  void addCentreCircle(perception::FieldFeatures& out);
  // Penalty corners from the penalty area's structure, from L-corners placed by the model check,
  // from one line's end.
  void addStructureCorners(perception::FieldFeatures& out);
  void addJunctionCorners(perception::FieldFeatures& out);
  void addLineEndCorners(perception::FieldFeatures& out);
  // Adds the penalty corner at `position` (robot frame); with `own` (its two lines), only when it
  // passes the model check (else its verdict is already recorded).
  void addCorner(const Vec2& position, const Vec2& toward_goal, bool left, bool inner,
                 double sigma_xy, double sigma_phi, const std::vector<Segment2>* own,
                 perception::FieldFeatures& out);
  // The lower features: L-corners and T-junctions not explained by a penalty corner, and lines.
  void addLowerFeatures(perception::FieldFeatures& out) const;
  // True if a penalty corner of the frame is at the junction.
  bool explained(const Junction& j) const;
  // An L whose lines are too short or too sparse to place it leaves its place to the line-end
  // rule (the longer line's end is the corner).
  bool placeable(const Junction& j) const;
  // The penalty corners found in the frame so far.
  std::vector<Vec2> corners_seen_;

  // Runs the model check on the feature at `local` (robot frame) whose first reference mark is
  // `mark`, with the other points those away from `own` (when given); records the verdict and
  // returns it.
  bool passesModelCheck(perception::FeatureKind kind, const geometry::Pose2& local,
                        const geometry::Pose2& mark, const std::vector<Segment2>* own);
  // True if the pose of `c` leaves no long stretch of line unseen (records c.unseen).
  bool passesUnseen(CheckedFeature& c);
  bool unseen_indexed_ = false;
  std::vector<Vec2> others_;
  // The high-level features of the frame so far: (index into the output's features, index into
  // checked_).
  std::vector<std::pair<int, int>> high_level_;
  // Drops the high-level features whose pose disagrees with the best fitting one's.
  void dropInconsistent(perception::FieldFeatures& out);
  std::vector<unsigned char> drop_;  // per output feature (kept from frame to frame)
  std::vector<int> new_index_;
};

}  // namespace fieldline::feature_recognition
