// One frame of fieldline-eval-features: its line points, its hypotheses against the truth, the
// fresh-pipeline check and the detailed view of one frame.
#include "tools/eval_features/frame_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "common/camera/image_io.hpp"
#include "common/perception/line_points_csv.hpp"

namespace fieldline::eval_features {

// Position and heading error of `h` against the nearer of the true pose and its twin.
void errorsAgainst(const Pose2& truth, const Pose2& h, double& position, double& heading) {
  const Pose2 twin{-truth.x, -truth.y, geometry::normalizeAngle(truth.phi + kPi)};
  const double e1 = (h.position() - truth.position()).norm();
  const double e2 = (h.position() - twin.position()).norm();
  const Pose2& near = e1 <= e2 ? truth : twin;
  position = std::min(e1, e2);
  heading = std::abs(geometry::angleDiff(h.phi, near.phi));
}

// The frame's line points from the region tracker, independent of earlier frames: the tracker
// starts afresh and tracks the frame twice (the first pass finds the regions, the second
// follows them as in a running camera). Afresh means as built, not only reinitialised: the
// tracker's frame counter sets the phases of its interleaved work (the mask-edge cells every
// 2nd frame, the view-edge seeds every 4th cell, the search inside the parent every 16 frames)
// and a class's frames_lost outlives reinitialise(), so a reinitialised tracker tracked frame K
// differently depending on the frame the run started at (frame 87411 of 100,000 frames gave a
// false hypothesis in the whole run, not with --first-frame 87411).
void visionOf(region_tracking::SimCamera& sim, region_tracking::FrameProcessor& processor,
              const camera::SimScene& scene, region_tracking::VisionResult& vision) {
  const camera::FrameView view = sim.render(scene);
  region_tracking::RegionTracker& tracker = processor.tracker();
  tracker =
      region_tracking::RegionTracker(processor.grid(), tracker.config(), processor.dontTouch());
  processor.process(view, true, vision);
  processor.process(view, true, vision);
}

FrameResult evaluate(const Pose2& pose, const perception::FieldFeatures& features,
                     const std::vector<CornerSite>& sites, double circle_radius) {
  FrameResult r;
  r.record.position = pose.position();
  bool correct_circle = false;
  for (const auto& h : features.hypotheses) {
    ++r.hypotheses;
    double position = 0, heading = 0;
    errorsAgainst(pose, h.pose, position, heading);
    if (position > kFalseDistance || heading > kFalseAngle) {
      ++r.false_hypotheses;
      r.record.false_hypothesis = true;
      continue;
    }
    r.position_errors.push_back(position);
    r.heading_errors.push_back(heading * 180 / kPi);
    if (features.features[h.feature].kind == FeatureKind::kCentreCircle) correct_circle = true;
  }
  r.record.detected[kCircle] = correct_circle;
  r.circle_eligible = pose.position().norm() + circle_radius <= kViewDistance;
  r.circle_found = r.circle_eligible && correct_circle;
  for (const CornerSite& site : sites) {
    bool found = false;
    for (const auto& feature : features.features) {
      if (feature.kind != FeatureKind::kPenaltyCorner) continue;
      const Vec2 seen = geometry::pointRobotToField(pose, {feature.local.x, feature.local.y});
      if ((seen - site.position).norm() <= kFalseDistance) found = true;
    }
    if (found) {
      r.record.detected[site.inner ? (site.left ? kLeftInner : kRightInner)
                                   : (site.left ? kLeftOuter : kRightOuter)] = true;
    }
    const double distance = (site.position - pose.position()).norm();
    if (distance <= kViewDistance) {
      ++r.corner_eligible;
      if (found) ++r.corner_found;
      r.eligible_corners.push_back({static_cast<int>(&site - sites.data()), distance, found});
    }
  }
  return r;
}

// The recogniser's and the region tracker's parameters from the options.
feature_recognition::RecognitionParams recognitionParamsOf(const Options& options) {
  feature_recognition::RecognitionParams recognition_params;
  if (options.recognition.alone_side_points >= 0)
    recognition_params.line_end_alone_side_points = options.recognition.alone_side_points;
  if (options.recognition.max_beyond_points >= -1)
    recognition_params.line_end_max_beyond_points = options.recognition.max_beyond_points;
  if (options.recognition.goal_shadow >= 0)
    recognition_params.model_check_goal_shadow = options.recognition.goal_shadow;
  if (options.recognition.identity_max_beyond >= -1)
    recognition_params.identity_max_beyond_points = options.recognition.identity_max_beyond;
  if (options.recognition.identity_beyond_reach >= 0.0)
    recognition_params.identity_beyond_reach = options.recognition.identity_beyond_reach;
  if (options.recognition.beyond_from >= 0.0)
    recognition_params.line_end_beyond_from = options.recognition.beyond_from;
  if (options.recognition.max_unseen >= -1.0)
    recognition_params.unseen_max_stretch = options.recognition.max_unseen;
  if (options.recognition.unseen_range > 0.0)
    recognition_params.unseen_range = options.recognition.unseen_range;
  if (options.recognition.veto_margin >= -1.0)
    recognition_params.consistency_veto_margin = options.recognition.veto_margin;
  return recognition_params;
}

region_tracking::VisionParams visionParamsOf(const Options& options) {
  region_tracking::VisionParams vision_params = region_tracking::defaultVisionParams();
  if (options.lines.sample_spacing > 0) {
    vision_params.lines.sample_spacing = options.lines.sample_spacing;
    vision_params.lines.sample_spacing_m = 0.0;  // sampling by contour index asked for
  }
  if (options.lines.sample_spacing_m >= 0.0)
    vision_params.lines.sample_spacing_m = options.lines.sample_spacing_m;
  if (options.lines.sample_min_px > 0.0)
    vision_params.lines.sample_min_px = options.lines.sample_min_px;
  if (options.lines.turn_spacing_m >= 0.0)
    vision_params.lines.turn_spacing_m = options.lines.turn_spacing_m;
  if (options.lines.turn_reach_m >= 0.0)
    vision_params.lines.turn_reach_m = options.lines.turn_reach_m;
  if (options.lines.turn_range_m >= 0.0)
    vision_params.lines.turn_range_m = options.lines.turn_range_m;
  if (options.lines.refine_range_m >= 0.0)
    vision_params.lines.refine_range_m = options.lines.refine_range_m;
  if (options.lines.refine_min_range_m >= 0.0)
    vision_params.lines.refine_min_range_m = options.lines.refine_min_range_m;
  if (options.lines.refine_turn > 0.0) vision_params.lines.refine_turn = options.lines.refine_turn;
  if (options.lines.refine_isolated) vision_params.lines.refine_isolated = true;
  if (options.lines.refine_spacing_m >= 0.0)
    vision_params.lines.refine_spacing_m = options.lines.refine_spacing_m;
  if (options.lines.refine_samples > 0)
    vision_params.lines.refine_samples = options.lines.refine_samples;
  if (options.lines.refine_reach > 0) vision_params.lines.refine_reach = options.lines.refine_reach;
  return vision_params;
}

// True if frame `frame` at `pose`, evaluated by a freshly built pipeline, gives the same line
// points and hypotheses as `vision` and `features` (from the running one); prints the
// difference otherwise.
bool sameAsFresh(const Options& options, const Pose2& pose, std::uint64_t frame,
                 const region_tracking::VisionResult& vision,
                 const perception::FieldFeatures& features) {
  Pipeline fresh(options);
  region_tracking::VisionResult fresh_vision;
  perception::FieldFeatures fresh_features;
  visionOf(fresh.sim, fresh.processor, sceneFor(pose, frame, options, fresh.sim.field),
           fresh_vision);
  fresh.recognizer.recognize(fresh_vision.lines, fresh_features);
  bool same = fresh_vision.lines.points.size() == vision.lines.points.size() &&
              fresh_vision.lines.sequences == vision.lines.sequences &&
              fresh_features.hypotheses.size() == features.hypotheses.size();
  for (std::size_t i = 0; same && i < vision.lines.points.size(); ++i) {
    same = fresh_vision.lines.points[i].x == vision.lines.points[i].x &&
           fresh_vision.lines.points[i].y == vision.lines.points[i].y;
  }
  for (std::size_t i = 0; same && i < features.hypotheses.size(); ++i) {
    const Pose2& a = features.hypotheses[i].pose;
    const Pose2& b = fresh_features.hypotheses[i].pose;
    same = a.x == b.x && a.y == b.y && a.phi == b.phi;
  }
  if (!same) {
    std::cerr << "frame " << frame << " differs from a fresh pipeline's: line points "
              << vision.lines.points.size() << " / " << fresh_vision.lines.points.size()
              << ", hypotheses " << features.hypotheses.size() << " / "
              << fresh_features.hypotheses.size() << "\n";
  }
  return same;
}
// the corners within 4 m; optionally the camera image with the line points and the points as CSV.
int detailFrame(const Options& options, region_tracking::SimCamera& sim,
                region_tracking::FrameProcessor& processor,
                feature_recognition::FeatureRecognizer& recognizer, const Pose2& pose,
                std::uint64_t frame) {
  region_tracking::VisionResult vision;
  perception::FieldFeatures features;
  const camera::SimScene scene = sceneFor(pose, frame, options, sim.field);
  visionOf(sim, processor, scene, vision);
  if (!options.output.dump.empty()) {
    std::ofstream out(options.output.dump);
    perception::writeLinePointsCsv(out, vision.lines);
  }
  if (!options.output.image.empty()) {
    cv::Mat image = camera::toBgrImage(sim.renderer->view(sim.frame));
    for (std::size_t s = 0; s < vision.lines.sequences.size(); ++s) {
      const auto [begin, end] = vision.lines.sequences[s];
      const cv::Scalar colour = s % 2 ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 0, 255);
      for (int i = begin; i < end; ++i) {
        const auto& p = vision.lines.points[static_cast<std::size_t>(i)];
        cv::circle(image, {static_cast<int>(p.u), static_cast<int>(p.v)}, 1, colour, -1);
      }
    }
    camera::writeImage(options.output.image, image);
  }
  recognizer.recognize(vision.lines, features);
  std::cout << "frame=" << frame << " pose=" << pose.x << "," << pose.y << "," << pose.phi
            << " robots=" << scene.robots.size() << " boxes=" << scene.boxes.size() << "\n";
  for (const auto& h : features.hypotheses) {
    double position = 0, heading = 0;
    errorsAgainst(pose, h.pose, position, heading);
    std::cout << "hypothesis kind=" << static_cast<int>(features.features[h.feature].kind)
              << " pose=" << h.pose.x << "," << h.pose.y << "," << h.pose.phi
              << " error_m=" << position << " error_deg=" << heading * 180 / kPi << "\n";
  }
  for (const auto& c : recognizer.checked()) {
    double position = 0, heading = 0;
    errorsAgainst(pose, c.robot, position, heading);
    std::cout << "model_check kind=" << static_cast<int>(c.kind) << " local=" << c.local.x << ","
              << c.local.y << "," << c.local.phi << " share=" << c.fit.share()
              << " points=" << c.fit.points << " others_share=" << c.others.share()
              << " others=" << c.others.points << " rival=" << c.rival_share
              << " shifted=" << c.shifted_share << " side_points=" << c.side_points
              << " beyond_points=" << c.beyond_points << " unseen=" << c.unseen
              << " accepted=" << c.accepted << " error_m=" << position << "\n";
  }
  for (const CornerSite& site : cornerSites(sim.field)) {
    const double d = (site.position - pose.position()).norm();
    if (d > kViewDistance) continue;
    const Vec2 local = geometry::pointFieldToRobot(pose, site.position);
    std::cout << "corner_within_4m inner=" << site.inner << " left=" << site.left
              << " opponent_goal=" << site.opponent_goal << " distance=" << d
              << " local=" << local.transpose() << "\n";
  }
  const auto& structure = recognizer.structure();
  for (int a = 0; a < 2; ++a) {
    for (const auto& g : structure.groups[a]) {
      std::cout << "group axis=" << a << " t=" << g.t << " length=" << g.line.length()
                << " rms=" << g.line.rms << " n=" << g.line.count
                << " start=" << g.line.start().transpose() << " end=" << g.line.end().transpose()
                << "\n";
    }
  }
  const auto& contours = recognizer.contours();
  for (const auto& piece : contours.pieces) {
    const Vec2* p = contours.points.data() + piece.begin;
    const auto line = feature_recognition::fitLine(p, piece.size());
    std::cout << "piece n=" << piece.size()
              << " turn=" << feature_recognition::pieceTurn(p, piece.size()) << " rms=" << line.rms
              << " length=" << line.length() << " from=" << p[0].transpose()
              << " to=" << p[piece.size() - 1].transpose() << "\n";
  }
  std::cout << "pieces=" << contours.pieces.size()
            << " lines=" << recognizer.classified().lines.size()
            << " arcs=" << recognizer.classified().arcs.size()
            << " penalty=" << recognizer.penaltyFound()
            << " corners=" << recognizer.penalty().corners.size()
            << " points=" << vision.lines.points.size()
            << " sequences=" << vision.lines.sequences.size()
            << " features=" << features.features.size() << "\n";
  return 0;
}

}  // namespace fieldline::eval_features
