// fieldline-eval-features' run over the scanning path: the totals of every frame, the per-frame
// CSV files, the detection maps, summary.json and the closing lines.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/geometry/fitting.hpp"
#include "tools/eval_features/eval_features.hpp"
#include "tools/eval_features/frame_evaluation.hpp"

namespace fieldline::eval_features {
namespace {

// Draws the field's lines thinly into an image, field +x right, +y up.
struct MapCanvas {
  double scale;
  Vec2 half;
  cv::Mat image;
  MapCanvas(const field::FieldModel& field, double px_per_m) : scale(px_per_m) {
    half = field.carpetHalfExtent();
    image = cv::Mat(static_cast<int>(2 * half.y() * scale), static_cast<int>(2 * half.x() * scale),
                    CV_8UC3, cv::Scalar(40, 110, 40));
    for (const auto& s : field.segments()) {
      cv::line(image, px(s.a), px(s.b), cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
    }
    for (const auto& arc : field.arcs()) {
      const int steps = 64;
      for (int i = 0; i < steps; ++i) {
        const Vec2 p0 = arc.pointAt(arc.start_angle + arc.sweep * i / steps);
        const Vec2 p1 = arc.pointAt(arc.start_angle + arc.sweep * (i + 1) / steps);
        cv::line(image, px(p0), px(p1), cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
      }
    }
  }
  cv::Point px(const Vec2& p) const {
    return {static_cast<int>(std::lround((p.x() + half.x()) * scale)),
            static_cast<int>(std::lround((half.y() - p.y()) * scale))};
  }
};

// The totals over the frames run.
struct Totals {
  std::vector<FrameRecord> records;
  std::vector<double> position_errors, heading_errors;
  long false_hypotheses = 0, hypotheses = 0;
  long circle_eligible = 0, circle_found = 0, corner_eligible = 0, corner_found = 0;
  long frames_with_feature = 0;
  // Corners within 4 m the camera can see (seeable()) and those of them found.
  long corner_seeable = 0, corner_seeable_found = 0;
  double line_points = 0.0;
  // Line points by range from the robot: within 2 m, 2-4 m, beyond 4 m.
  std::array<double, 3> line_points_by_range{};
  // The line detector's work in the frame's second pass (its cost): scans and pixels read.
  double line_scans = 0.0, line_pixels = 0.0;
  long fresh_checked = 0, fresh_differ = 0;

  void addLines(const region_tracking::VisionResult& vision,
                region_tracking::FrameProcessor& processor) {
    line_points += static_cast<double>(vision.lines.points.size());
    line_scans += processor.lineDetector().scans();
    line_pixels += processor.lineDetector().pixelsRead();
    for (const perception::LinePoint& p : vision.lines.points) {
      const double range = std::hypot(p.x, p.y);
      ++line_points_by_range[range < 2.0 ? 0 : range < kViewDistance ? 1 : 2];
    }
  }

  void add(const FrameResult& r) {
    hypotheses += r.hypotheses;
    false_hypotheses += r.false_hypotheses;
    if (r.hypotheses > 0) ++frames_with_feature;
    circle_eligible += r.circle_eligible;
    circle_found += r.circle_found;
    corner_eligible += r.corner_eligible;
    corner_found += r.corner_found;
    position_errors.insert(position_errors.end(), r.position_errors.begin(),
                           r.position_errors.end());
    heading_errors.insert(heading_errors.end(), r.heading_errors.begin(), r.heading_errors.end());
    records.push_back(r.record);
  }
};

// The figures of a run, from its totals.
struct Summary {
  double circle_rate = 0.0, corner_rate = 0.0, corner_seeable_rate = 0.0;
  double pos_median = 0.0, heading_median = 0.0;
  double points_per_frame = 0.0;
  std::array<double, 3> points_by_range{};
  double line_scans = 0.0, line_pixels = 0.0;
};

double medianOrZero(const std::vector<double>& values) {
  return values.empty() ? 0.0 : geometry::median(values);
}

Summary summarise(const Totals& t) {
  Summary s;
  s.circle_rate = t.circle_eligible ? double(t.circle_found) / t.circle_eligible : 0.0;
  s.corner_rate = t.corner_eligible ? double(t.corner_found) / t.corner_eligible : 0.0;
  s.corner_seeable_rate =
      t.corner_seeable ? double(t.corner_seeable_found) / t.corner_seeable : 0.0;
  s.pos_median = medianOrZero(t.position_errors);
  s.heading_median = medianOrZero(t.heading_errors);
  const double frames_counted = static_cast<double>(std::max<std::size_t>(t.records.size(), 1));
  s.points_per_frame = t.line_points / frames_counted;
  s.line_scans = t.line_scans / frames_counted;
  s.line_pixels = t.line_pixels / frames_counted;
  for (std::size_t k = 0; k < s.points_by_range.size(); ++k) {
    s.points_by_range[k] = t.line_points_by_range[k] / frames_counted;
  }
  return s;
}

// The per-frame CSV files asked for (--check-csv, --misses-csv, --circle-misses-csv).
class FrameCsvs {
 public:
  explicit FrameCsvs(const OutputOptions& output) {
    if (!output.circle_misses_csv.empty()) {
      circle_misses_.open(output.circle_misses_csv);
      circle_misses_ << "frame,x,y,phi,occluded_share,arcs,circle_found,coverage_rad,oriented,"
                        "checked,share\n";
    }
    if (!output.misses_csv.empty()) {
      misses_.open(output.misses_csv);
      misses_ << "frame,inner,left,opponent_goal,distance,local_x,local_y,x,y,cause,zone,"
                 "blocked,front_visible,side_visible,front_points,side_points,front_group,"
                 "side_group,junction,structure_corner,checked\n";
    }
    if (!output.check_csv.empty()) {
      checks_.open(output.check_csv);
      checks_ << "frame,kind,share,points,others_share,others,accepted,error_m,error_deg,"
                 "rival_share,shifted_share,side_points,beyond_points,unseen_m\n";
    }
  }

  // Every penalty corner within 4 m that was not found, with the diagnosis of why.
  void writeMisses(int f, const Pose2& pose, const camera::SimScene& scene, const FrameResult& r,
                   const std::vector<CornerSite>& sites, const region_tracking::SimCamera& sim,
                   const perception::LinePoints& lines,
                   const feature_recognition::FeatureRecognizer& recognizer) {
    if (!misses_.is_open()) return;
    for (const auto& [site, distance, found] : r.eligible_corners) {
      if (found) continue;
      const Vec2 local = geometry::pointFieldToRobot(pose, sites[site].position);
      const MissDiagnosis m = diagnoseMiss(sites[site], pose, scene, sim, lines, recognizer);
      misses_ << f << "," << sites[site].inner << "," << sites[site].left << ","
              << sites[site].opponent_goal << "," << distance << "," << local.x() << ","
              << local.y() << "," << pose.x << "," << pose.y << "," << m.cause << "," << m.zone
              << "," << m.blocked << "," << m.front_visible << "," << m.side_visible << ","
              << m.front_points << "," << m.side_points << "," << m.front_group << ","
              << m.side_group << "," << m.junction << "," << m.structure_corner << "," << m.checked
              << "\n";
    }
  }

  // Why the centre circle was missed: occluded share, the stage reached, the model check.
  void writeCircleMiss(int f, const Pose2& pose, const camera::SimScene& scene,
                       const FrameResult& r, const region_tracking::SimCamera& sim,
                       const feature_recognition::FeatureRecognizer& recognizer,
                       double circle_radius) {
    if (!circle_misses_.is_open() || !r.circle_eligible || r.circle_found) return;
    const auto& circle = recognizer.circle();
    int checked = -1;
    double share = 0.0;
    for (const auto& c : recognizer.checked()) {
      if (c.kind == perception::FeatureKind::kCentreCircle) {
        checked = c.accepted;
        share = c.fit.share();
      }
    }
    circle_misses_ << f << "," << pose.x << "," << pose.y << "," << pose.phi << ","
                   << occludedCircleShare(scene, circle_radius,
                                          sim.mirror.params().reference_height,
                                          sim.renderer->params().robot_height)
                   << "," << recognizer.classified().arcs.size() << "," << circle.found << ","
                   << circle.coverage << "," << circle.oriented << "," << checked << "," << share
                   << "\n";
  }

  // Every model check: its fits, its verdict and the error of its pose.
  void writeChecks(int f, const Pose2& pose,
                   const feature_recognition::FeatureRecognizer& recognizer) {
    if (!checks_.is_open()) return;
    for (const auto& c : recognizer.checked()) {
      double position = 0, heading = 0;
      errorsAgainst(pose, c.robot, position, heading);
      checks_ << f << "," << static_cast<int>(c.kind) << "," << c.fit.share() << "," << c.fit.points
              << "," << c.others.share() << "," << c.others.points << "," << c.accepted << ","
              << position << "," << heading * 180 / kPi << "," << c.rival_share << ","
              << c.shifted_share << "," << c.side_points << "," << c.beyond_points << ","
              << c.unseen << "\n";
    }
  }

 private:
  std::ofstream checks_, misses_, circle_misses_;
};

// The detection maps (seed fig. 4.59), one per kind: where it was found, where not, where a
// false hypothesis came.
void writeMaps(const std::string& out_dir, const field::FieldModel& field,
               const std::vector<FrameRecord>& records) {
  for (int k = 0; k < kMapKinds; ++k) {
    MapCanvas canvas(field, 30.0);
    for (const FrameRecord& r : records) {
      if (!r.detected[k]) cv::circle(canvas.image, canvas.px(r.position), 1, {70, 70, 70}, -1);
    }
    for (const FrameRecord& r : records) {
      if (r.detected[k]) {
        cv::circle(canvas.image, canvas.px(r.position), 2, {0, 220, 255}, -1, cv::LINE_AA);
      }
    }
    for (const FrameRecord& r : records) {
      if (r.false_hypothesis) {
        cv::drawMarker(canvas.image, canvas.px(r.position), {0, 0, 255}, cv::MARKER_CROSS, 7, 2);
      }
    }
    cv::putText(canvas.image, kMapNames[k], {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {255, 255, 255},
                1, cv::LINE_AA);
    cv::imwrite(out_dir + "/detection_" + kMapNames[k] + ".png", canvas.image);
  }
}

void writeSummaryJson(const Options& options, const Totals& t, const Summary& s) {
  std::ofstream json(options.output.out_dir + "/summary.json");
  json << "{\n  \"frames\": " << t.records.size() << ",\n  \"field\": \"" << options.field
       << "\",\n  \"clutter\": " << (options.scene.clutter ? "true" : "false")
       << ",\n  \"seed\": " << options.seed << ",\n  \"hypotheses\": " << t.hypotheses
       << ",\n  \"false_hypotheses\": " << t.false_hypotheses
       << ",\n  \"frames_with_hypotheses\": " << t.frames_with_feature
       << ",\n  \"circle_eligible_frames\": " << t.circle_eligible
       << ",\n  \"circle_found\": " << t.circle_found << ",\n  \"circle_rate\": " << s.circle_rate
       << ",\n  \"corner_eligible\": " << t.corner_eligible
       << ",\n  \"corner_found\": " << t.corner_found << ",\n  \"corner_rate\": " << s.corner_rate
       << ",\n  \"corner_seeable\": " << t.corner_seeable
       << ",\n  \"corner_seeable_found\": " << t.corner_seeable_found
       << ",\n  \"corner_seeable_rate\": " << s.corner_seeable_rate
       << ",\n  \"pos_median_m\": " << s.pos_median
       << ",\n  \"heading_median_deg\": " << s.heading_median
       << ",\n  \"line_points_per_frame\": " << s.points_per_frame
       << ",\n  \"line_points_per_frame_within_2m\": " << s.points_by_range[0]
       << ",\n  \"line_points_per_frame_2_to_4m\": " << s.points_by_range[1]
       << ",\n  \"line_points_per_frame_beyond_4m\": " << s.points_by_range[2]
       << ",\n  \"line_scans_per_frame\": " << s.line_scans
       << ",\n  \"line_pixels_per_frame\": " << s.line_pixels << "\n}\n";
}

// The closing lines on stdout; the exit code (1 for a false hypothesis, a fresh check that
// differed or a required rate missed).
int report(const Options& options, const Totals& t, const Summary& s) {
  std::cout << "line_points_per_frame=" << s.points_per_frame
            << " within_2m=" << s.points_by_range[0] << " 2_to_4m=" << s.points_by_range[1]
            << " beyond_4m=" << s.points_by_range[2] << " scans=" << s.line_scans
            << " pixels_read=" << s.line_pixels << "\n";
  // The corners within 4 m that the camera can see at all (see seeable()): the rest stand behind
  // an opponent, in the robot's own reflection or beyond the mirror's useful radius. Both rates
  // are reported; corner_rate in the last line counts every corner within 4 m.
  std::cout << "corner_eligible=" << t.corner_eligible << " corner_seeable=" << t.corner_seeable
            << " corner_seeable_rate=" << s.corner_seeable_rate << "\n";
  std::cout << "frames=" << t.records.size() << " false_hypotheses=" << t.false_hypotheses
            << " circle_rate=" << s.circle_rate << " corner_rate=" << s.corner_rate
            << " pos_median_m=" << s.pos_median << " heading_median_deg=" << s.heading_median
            << std::endl;
  if (options.check_fresh_every > 0) {
    std::cout << "fresh_checked=" << t.fresh_checked << " fresh_differ=" << t.fresh_differ << "\n";
  }
  bool ok = t.false_hypotheses == 0 && t.fresh_differ == 0;
  if (options.min_circle_rate >= 0 && s.circle_rate < options.min_circle_rate) ok = false;
  if (options.min_corner_rate >= 0 && s.corner_rate < options.min_corner_rate) ok = false;
  return ok ? 0 : 1;
}

// The frames [first_frame, first_frame + count) of `path`, evaluated one by one.
Totals runFrames(const Options& options, Pipeline& pipeline, const std::vector<Pose2>& path) {
  region_tracking::SimCamera& sim = pipeline.sim;
  feature_recognition::FeatureRecognizer& recognizer = pipeline.recognizer;
  region_tracking::FrameProcessor& processor = pipeline.processor;
  region_tracking::VisionResult vision;
  perception::FieldFeatures features;
  const std::vector<CornerSite> sites = cornerSites(sim.field);
  const double circle_radius = sim.field.dimensions().centre_circle_radius;
  Totals t;
  FrameCsvs csvs(options.output);
  const int last_frame = options.count > 0 ? std::min(static_cast<int>(path.size()),
                                                      options.first_frame + options.count)
                                           : static_cast<int>(path.size());
  for (int f = options.first_frame; f < last_frame; ++f) {
    const Pose2& pose = path[f];
    const camera::SimScene scene =
        sceneFor(pose, static_cast<std::uint64_t>(f), options, sim.field);
    visionOf(sim, processor, scene, vision);
    recognizer.recognize(vision.lines, features);
    if (options.check_fresh_every > 0 &&
        (f - options.first_frame) % options.check_fresh_every == 0) {
      ++t.fresh_checked;
      if (!sameAsFresh(options, pose, static_cast<std::uint64_t>(f), vision, features)) {
        ++t.fresh_differ;
      }
    }
    t.addLines(vision, processor);
    const FrameResult r = evaluate(pose, features, sites, circle_radius);
    for (const auto& e : r.eligible_corners) {
      MissDiagnosis v;
      cornerVisibility(sites[e.site], pose, scene, sim, v);
      if (!seeable(v)) continue;
      ++t.corner_seeable;
      if (e.found) ++t.corner_seeable_found;
    }
    csvs.writeMisses(f, pose, scene, r, sites, sim, vision.lines, recognizer);
    csvs.writeCircleMiss(f, pose, scene, r, sim, recognizer, circle_radius);
    csvs.writeChecks(f, pose, recognizer);
    if (r.false_hypotheses > 0) {
      std::cerr << "false hypothesis: frame " << f << " pose " << pose.x << "," << pose.y << ","
                << pose.phi << " (" << r.false_hypotheses << " of " << r.hypotheses << ")\n";
    }
    t.add(r);
    if (options.output.progress && (f + 1) % 1000 == 0) {
      std::cerr << "progress: " << f + 1 << "/" << path.size() << " false=" << t.false_hypotheses
                << " circle=" << t.circle_found << "/" << t.circle_eligible
                << " corner=" << t.corner_found << "/" << t.corner_eligible << std::endl;
    }
  }
  return t;
}

}  // namespace

int run(const Options& options) {
  const auto pipeline = std::make_unique<Pipeline>(options);
  region_tracking::SimCamera& sim = pipeline->sim;
  const std::vector<Pose2> path = scanPath(sim.field, options.frames);
  if (!options.pose.empty()) {
    Pose2 pose;
    char c1 = 0, c2 = 0;
    std::istringstream in(options.pose);
    if (!(in >> pose.x >> c1 >> pose.y >> c2 >> pose.phi) || c1 != ',' || c2 != ',') {
      std::cerr << "--pose wants x,y,phi (m, m, rad)\n";
      return 2;
    }
    return detailFrame(options, sim, pipeline->processor, pipeline->recognizer, pose,
                       static_cast<std::uint64_t>(std::max(options.frame, 0)));
  }
  if (options.frame >= 0) {
    if (options.frame >= static_cast<int>(path.size())) {
      std::cerr << "--frame must be below --frames\n";
      return 2;
    }
    return detailFrame(options, sim, pipeline->processor, pipeline->recognizer, path[options.frame],
                       static_cast<std::uint64_t>(options.frame));
  }
  const Totals totals = runFrames(options, *pipeline, path);
  const Summary summary = summarise(totals);
  if (!options.output.out_dir.empty()) {
    std::filesystem::create_directories(options.output.out_dir);
    writeMaps(options.output.out_dir, sim.field, totals.records);
    writeSummaryJson(options, totals, summary);
  }
  if (options.occlusion_frames > 0) {
    occlusionSeries(options, sim, pipeline->processor, pipeline->recognizer);
  }
  return report(options, totals, summary);
}

}  // namespace fieldline::eval_features
