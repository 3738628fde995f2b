#include "services/feature_recognition/recognizer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "services/feature_recognition/pose_hypotheses.hpp"

namespace fieldline::feature_recognition {

using perception::FeatureKind;
using perception::FieldFeature;

FeatureRecognizer::FeatureRecognizer(const field::FieldModel& field, RecognitionParams params)
    : field_(field),
      params_(params),
      model_check_(field, params),
      unseen_(field, params),
      model_junctions_(modelJunctions(field)) {}

bool FeatureRecognizer::passesModelCheck(FeatureKind kind, const Pose2& local, const Pose2& mark,
                                         const std::vector<Segment2>* own) {
  // The field is point-symmetric: every reference mark of a feature gives the same fit, so one
  // is enough.
  CheckedFeature c;
  c.kind = kind;
  c.local = local;
  c.robot = robotPoseFrom(mark, local);
  c.fit = model_check_.fit(contours_.points, c.robot);
  if (own == nullptr) {
    c.accepted = model_check_.accepts(c.fit);
  } else {
    pointsAwayFrom(contours_.points, *own, params_.identity_leg_margin, others_);
    c.others = model_check_.fit(others_, c.robot);
    c.accepted = model_check_.accepts(c.fit, c.others);
  }
  c.accepted = c.accepted && passesUnseen(c);
  checked_.push_back(c);
  return c.accepted;
}

bool FeatureRecognizer::passesUnseen(CheckedFeature& c) {
  if (params_.unseen_max_stretch < 0.0) return true;
  if (!unseen_indexed_) {  // once per frame, and only in frames with a feature to check
    unseen_.index(contours_.points);
    unseen_indexed_ = true;
  }
  c.unseen = unseen_.longestUnseen(c.robot);
  return unseen_.accepts(c.unseen);
}

void FeatureRecognizer::dropInconsistent(perception::FieldFeatures& out) {
  if (high_level_.empty()) return;
  const auto agree = [&](const Pose2& a, const Pose2& b) {
    const bool same = (a.position() - b.position()).norm() <= params_.consistency_distance &&
                      std::abs(geometry::angleDiff(a.phi, b.phi)) <= params_.consistency_angle;
    const bool twin =
        (a.position() + b.position()).norm() <= params_.consistency_distance &&
        std::abs(geometry::angleDiff(a.phi + std::numbers::pi, b.phi)) <= params_.consistency_angle;
    return same || twin;
  };
  // A feature refused by its own tests (too few points of its own, a rival, the L test), not by
  // what its pose leaves unseen, whose pose fits all the points clearly better than an accepted
  // one's speaks against that pose.
  const auto vetoed = [&](const CheckedFeature& accepted) {
    if (params_.consistency_veto_margin < 0.0) return false;
    for (const CheckedFeature& c : checked_) {
      if (c.accepted || c.inconsistent || !unseen_.accepts(c.unseen)) continue;
      if (c.fit.share() >= accepted.fit.share() + params_.consistency_veto_margin &&
          !agree(c.robot, accepted.robot)) {
        return true;
      }
    }
    return false;
  };
  drop_.assign(out.features.size(), 0);
  new_index_.resize(out.features.size());
  // Vetoed features first; of the others, the one that fits the most points sets the pose.
  int best = -1;
  bool any = false;
  for (const auto& [feature, check] : high_level_) {
    if (vetoed(checked_[check])) {
      drop_[feature] = 1;
      any = true;
    } else if (best < 0 || checked_[check].fit.share() > checked_[best].fit.share()) {
      best = check;
    }
  }
  for (const auto& [feature, check] : high_level_) {
    if (drop_[feature] || agree(checked_[check].robot, checked_[best].robot)) continue;
    drop_[feature] = 1;
    any = true;
  }
  // Marked afterwards: a feature dropped here must not veto another.
  for (const auto& [feature, check] : high_level_) {
    if (!drop_[feature]) continue;
    checked_[check].accepted = false;
    checked_[check].inconsistent = true;
  }
  if (!any) return;
  int kept = 0;
  for (std::size_t f = 0; f < out.features.size(); ++f) {
    new_index_[f] = drop_[f] ? -1 : kept;
    if (!drop_[f]) out.features[kept++] = out.features[f];
  }
  out.features.resize(static_cast<std::size_t>(kept));
  std::erase_if(out.hypotheses,
                [&](const perception::PoseHypothesis& h) { return drop_[h.feature] != 0; });
  for (auto& h : out.hypotheses)
    h.feature = new_index_[h.feature];
}

InputCheck FeatureRecognizer::recognize(const perception::LinePoints& in,
                                        perception::FieldFeatures& out) {
  out.clear();
  const InputCheck check = runStages(in);
  // High-level features with their poses: the centre circle, then the penalty corners from the
  // area's structure (stage 5), L-corners identified by the model check (when the structure is
  // too sparse to be seen) and one line's end (when the corner's other line is too sparse for a
  // line).
  addCentreCircle(out);
  corners_seen_.clear();
  addStructureCorners(out);
  addJunctionCorners(out);
  if (params_.line_end_corners && structure_.found) addLineEndCorners(out);
  dropInconsistent(out);
  addLowerFeatures(out);
  rankHypotheses(out);
  return check;
}

InputCheck FeatureRecognizer::runStages(const perception::LinePoints& in) {
  circle_.clear();
  structure_.clear();
  junctions_.clear();
  checked_.clear();
  high_level_.clear();
  penalty_found_ = false;
  const InputCheck check = prepareContours(in, params_, contours_);
  classifyPieces(contours_, params_, classified_);
  // A field without a centre circle (or without penalty and goal areas) has none to find.
  if (field_.hasCentreCircle()) {
    findCircle(contours_, classified_, field_.dimensions().centre_circle_radius, params_, circle_);
  }
  buildLineStructure(contours_, classified_.lines,
                     circle_.found ? circle_.pieces : std::vector<int>{}, params_, structure_);
  if (circle_.found && structure_.found) {
    // The halfway line is a merged group: its parts on both sides of the circle count together.
    thread_local std::vector<Line> candidates;
    candidates.clear();
    for (const auto& groups : structure_.groups) {
      for (const LineGroup& g : groups)
        candidates.push_back(g.line);
    }
    findOrientationLine(candidates, params_, circle_);
  }
  penalty_found_ = field_.hasPenaltyAreas() && field_.hasGoalAreas() &&
                   findPenaltyArea(structure_, field_, params_, penalty_);
  findJunctions(structure_, params_, junctions_);
  unseen_indexed_ = false;
  return check;
}

void FeatureRecognizer::addCentreCircle(perception::FieldFeatures& out) {
  if (!circle_.found || !circle_.oriented) return;
  const Pose2 local{circle_.fit.centre.x(), circle_.fit.centre.y(),
                    std::atan2(circle_.line_direction.y(), circle_.line_direction.x())};
  const std::vector<Pose2> marks = centreCircleMarks();
  if (!passesModelCheck(FeatureKind::kCentreCircle, local, marks.front(), nullptr)) return;
  const int index = static_cast<int>(out.features.size());
  high_level_.emplace_back(index, static_cast<int>(checked_.size()) - 1);
  out.features.push_back({FeatureKind::kCentreCircle, local, qualityMeasure(0, 2)});
  Line line;
  line.rms = circle_.line_rms;
  line.count = circle_.line_count;
  line.t_max = circle_.line_length;
  const double sigma_position =
      circle_.fit.rms / std::sqrt(static_cast<double>(std::max(circle_.fit.count, 1)));
  addHypotheses(index, local, marks, sigma_position, lineAngleSigma(line), params_.min_sigma_xy,
                params_.min_sigma_phi, out.hypotheses);
}

void FeatureRecognizer::addCorner(const Vec2& position, const Vec2& toward_goal, bool left,
                                  bool inner, double sigma_xy, double sigma_phi,
                                  const std::vector<Segment2>* own,
                                  perception::FieldFeatures& out) {
  const Pose2 local{position.x(), position.y(), std::atan2(toward_goal.y(), toward_goal.x())};
  const std::vector<Pose2> marks = penaltyCornerMarks(field_, left, inner);
  if (own != nullptr && !passesModelCheck(FeatureKind::kPenaltyCorner, local, marks.front(), own)) {
    return;
  }
  corners_seen_.push_back(position);
  const int index = static_cast<int>(out.features.size());
  // Both ways here, the feature's verdict is the last one recorded.
  high_level_.emplace_back(index, static_cast<int>(checked_.size()) - 1);
  out.features.push_back({FeatureKind::kPenaltyCorner, local, qualityMeasure(0, 2)});
  addHypotheses(index, local, marks, sigma_xy, sigma_phi, params_.min_sigma_xy,
                params_.min_sigma_phi, out.hypotheses);
}

void FeatureRecognizer::addStructureCorners(perception::FieldFeatures& out) {
  if (!penalty_found_) return;
  for (const PenaltyCorner& corner : penalty_.corners) {
    const std::vector<Segment2> own = {{corner.front.start(), corner.front.end()},
                                       {corner.side.start(), corner.side.end()}};
    addCorner(corner.position, corner.toward_goal, corner.left, corner.inner, corner.sigma_xy,
              corner.sigma_phi, &own, out);
  }
}

bool FeatureRecognizer::explained(const Junction& j) const {
  for (const Vec2& c : corners_seen_) {
    if ((c - j.position).norm() < params_.corner_distance) return true;
  }
  return false;
}

bool FeatureRecognizer::placeable(const Junction& j) const {
  const Line& bar = structure_.groups[j.bar_axis][j.bar].line;
  const Line& stem = structure_.groups[j.stem_axis][j.stem].line;
  return j.is_t ||
         (bar.count >= params_.min_corner_line_points &&
          stem.count >= params_.min_corner_line_points &&
          bar.length() >= params_.min_identity_leg && stem.length() >= params_.min_identity_leg);
}

void FeatureRecognizer::addJunctionCorners(perception::FieldFeatures& out) {
  for (const Junction& j : junctions_) {
    if (j.is_t || explained(j) || !placeable(j)) continue;
    JunctionIdentity identity;
    const bool identified =
        identifyJunction(j, model_junctions_, contours_.points, model_check_, params_, identity);
    const ModelJunction* model = identity.model >= 0 ? &model_junctions_[identity.model] : nullptr;
    if (model == nullptr || !model->penalty_corner) continue;
    const Vec2 toward_goal = geometry::rotate(model->toward_goal, -identity.robot.phi);
    CheckedFeature c;
    c.kind = FeatureKind::kPenaltyCorner;
    c.local = {j.position.x(), j.position.y(), std::atan2(toward_goal.y(), toward_goal.x())};
    c.robot = identity.robot;
    c.fit = model_check_.fit(contours_.points, identity.robot);
    c.others = identity.fit;
    c.rival_share = identity.rival_share;
    // An L, not a T or two curves meeting: nothing near the corner off its two lines.
    c.beyond_points =
        pointsOffJunction(contours_.points, *model, identity.robot, params_.line_end_beyond_from,
                          params_.identity_beyond_reach);
    c.accepted = identified &&
                 (params_.identity_max_beyond_points < 0 ||
                  c.beyond_points <= params_.identity_max_beyond_points) &&
                 model_check_.accepts(c.fit, c.others);
    c.accepted = c.accepted && passesUnseen(c);
    checked_.push_back(c);
    if (!c.accepted) continue;
    const Line& a = structure_.groups[j.bar_axis][j.bar].line;
    const Line& b = structure_.groups[j.stem_axis][j.stem].line;
    const double sigma_phi = std::min(lineAngleSigma(a), lineAngleSigma(b));
    addCorner(j.position, toward_goal, model->left, model->inner,
              std::hypot(lineOffsetSigma(a), lineOffsetSigma(b)), sigma_phi, nullptr, out);
  }
}

void FeatureRecognizer::addLineEndCorners(perception::FieldFeatures& out) {
  thread_local std::vector<Vec2> taken;
  thread_local std::vector<LineEnd> ends;
  taken = corners_seen_;
  for (const Junction& j : junctions_) {
    if (placeable(j)) taken.push_back(j.position);
  }
  candidateLineEnds(structure_, field_, taken, params_, ends);
  for (const LineEnd& end : ends) {
    bool seen = false;
    for (const Vec2& c : corners_seen_) {
      if ((c - end.position).norm() < params_.junction_distance) seen = true;
    }
    if (seen) continue;
    LineEndIdentity identity;
    identifyLineEnd(end, model_junctions_, contours_.points, model_check_, params_, identity);
    const int m = identity.identity.model;
    if (m < 0 || !model_junctions_[m].penalty_corner) continue;
    const ModelJunction& model = model_junctions_[m];
    const Vec2 toward_goal = geometry::rotate(model.toward_goal, -identity.identity.robot.phi);
    CheckedFeature c;
    c.kind = FeatureKind::kPenaltyCorner;
    c.local = {identity.corner.x(), identity.corner.y(),
               std::atan2(toward_goal.y(), toward_goal.x())};
    c.robot = identity.identity.robot;
    c.fit = model_check_.fit(contours_.points, c.robot);
    c.others = identity.identity.fit;
    c.rival_share = identity.identity.rival_share;
    c.shifted_share = identity.shifted_share;
    c.side_points = identity.side_points;
    c.beyond_points = identity.beyond_points;
    c.accepted = identity.identified && model_check_.accepts(c.fit, c.others) && passesUnseen(c);
    checked_.push_back(c);
    if (!c.accepted) continue;
    const Line& line = structure_.groups[end.axis][end.group].line;
    addCorner(identity.corner, toward_goal, model.left, model.inner, lineOffsetSigma(line),
              lineAngleSigma(line), nullptr, out);
  }
}

void FeatureRecognizer::addLowerFeatures(perception::FieldFeatures& out) const {
  for (const Junction& j : junctions_) {
    if (explained(j)) continue;
    out.features.push_back({j.is_t ? FeatureKind::kTJunction : FeatureKind::kFieldCorner,
                            {j.position.x(), j.position.y(), j.phi},
                            qualityMeasure(0, j.is_t ? field_t_junctions_ : field_corners_)});
  }
  const double line_quality = qualityMeasure(1, static_cast<int>(field_.segments().size()));
  for (const auto& groups : structure_.groups) {
    for (const LineGroup& g : groups) {
      if (g.line.length() < params_.min_constraint_line) continue;
      // The foot of the perpendicular from the robot and the line's direction.
      const Vec2 foot = g.line.centre + g.line.along(Vec2::Zero()) * g.line.direction;
      out.features.push_back(
          {FeatureKind::kStraightLine,
           {foot.x(), foot.y(), std::atan2(g.line.direction.y(), g.line.direction.x())},
           line_quality});
    }
  }
}

}  // namespace fieldline::feature_recognition
