// fieldline-eval-features: renders frames at poses over the whole field (a scanning path with
// the robot turning through all headings, opponents and clutter around it), runs the region
// tracker and the feature recogniser on each, and compares every pose hypothesis with the true
// pose and its point-symmetric twin. Writes detection maps per feature kind (seed fig. 4.59), an
// occlusion series of the centre circle (fig. 4.60) and a JSON summary, and ends with
//   frames=N false_hypotheses=F circle_rate=A corner_rate=B pos_median_m=P heading_median_deg=H
//
//   fieldline-eval-features --frames 3000 --out build/eval_features
//   fieldline-eval-features --pose 1,0.5,0.3 --dump points.csv     (one frame's line points)
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/geometry/geometry.hpp"
#include "services/feature_recognition/points_csv.hpp"
#include "services/feature_recognition/recognizer.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tests/support/sim_frames.hpp"

namespace {

using namespace fieldline;
using geometry::Pose2;
using geometry::Vec2;
using perception::FeatureKind;

constexpr double kPi = std::numbers::pi;
// A hypothesis further than this from every symmetric image of the true pose is false.
constexpr double kFalseDistance = 0.5;
constexpr double kFalseAngle = 10.0 * kPi / 180.0;
// Features count as "in view" within this distance (the targets).
constexpr double kViewDistance = 4.0;

struct Options {
  int frames = 3000;
  std::string field = "msl";
  std::string camera = "omni_sim";
  bool clutter = true;
  int opponents = 3;
  std::uint32_t seed = 1;
  std::string out_dir;
  double min_circle_rate = -1.0;
  double min_corner_rate = -1.0;
  bool occlusion_series = true;
  std::string pose;
  std::string dump;
};

// The eight penalty-area corners: (inner, left) as seen toward their goal, and the goal.
struct CornerSite {
  Vec2 position;
  bool inner;
  bool left;
  bool opponent_goal;
};

std::vector<CornerSite> cornerSites(const field::FieldModel& field) {
  const auto& d = field.dimensions();
  std::vector<CornerSite> sites;
  for (int inner = 0; inner < 2; ++inner) {
    for (int left = 0; left < 2; ++left) {
      const double x = field.length() / 2 - (inner ? d.goal_area_depth : d.penalty_area_depth);
      const double y = (inner ? d.goal_area_width : d.penalty_area_width) / 2 * (left ? 1 : -1);
      sites.push_back({Vec2(x, y), inner != 0, left != 0, true});
      sites.push_back({Vec2(-x, -y), inner != 0, left != 0, false});
    }
  }
  return sites;
}

// Kinds of the detection maps (seed fig. 4.59).
enum MapKind { kCircle, kLeftOuter, kRightOuter, kLeftInner, kRightInner, kMapKinds };
const char* const kMapNames[kMapKinds] = {"centre_circle", "left_outer_corner",
                                          "right_outer_corner", "left_inner_corner",
                                          "right_inner_corner"};

struct FrameRecord {
  Vec2 position;
  bool detected[kMapKinds] = {};
  bool false_hypothesis = false;
};

// A path scanning the field in lanes along x (the carpet up to 0.5 m beyond the lines), the
// robot turning steadily so that every place is seen under many headings.
std::vector<Pose2> scanPath(const field::FieldModel& field, int frames) {
  const double half_x = field.length() / 2 + 0.5, half_y = field.width() / 2 + 0.5;
  const double lane = 0.8;
  std::vector<Vec2> corners;
  int k = 0;
  for (double y = -half_y; y <= half_y + 1e-9; y += lane, ++k) {
    corners.emplace_back(k % 2 ? half_x : -half_x, y);
    corners.emplace_back(k % 2 ? -half_x : half_x, y);
  }
  double total = 0.0;
  for (std::size_t i = 1; i < corners.size(); ++i)
    total += (corners[i] - corners[i - 1]).norm();
  std::vector<Pose2> poses;
  std::size_t segment = 1;
  double segment_start = 0.0;
  for (int f = 0; f < frames; ++f) {
    const double s = total * f / std::max(frames, 1);
    while (segment + 1 < corners.size() &&
           segment_start + (corners[segment] - corners[segment - 1]).norm() < s) {
      segment_start += (corners[segment] - corners[segment - 1]).norm();
      ++segment;
    }
    const Vec2 a = corners[segment - 1], b = corners[segment];
    const double t = std::clamp((s - segment_start) / std::max((b - a).norm(), 1e-9), 0.0, 1.0);
    const Vec2 p = a + t * (b - a);
    poses.push_back({p.x(), p.y(), geometry::normalizeAngle(0.37 * f)});
  }
  return poses;
}

// Opponents near the robot (never on it), deterministic per frame.
std::vector<camera::SimRobot> opponentsAround(const Pose2& robot, int count, std::mt19937& rng,
                                              const field::FieldModel& field) {
  std::vector<camera::SimRobot> out;
  std::uniform_real_distribution<double> distance(1.0, 5.0), bearing(-kPi, kPi);
  const Vec2 half = field.carpetHalfExtent();
  for (int i = 0; i < count; ++i) {
    const double d = distance(rng), b = bearing(rng);
    const Vec2 p = robot.position() + d * Vec2(std::cos(b), std::sin(b));
    if (std::abs(p.x()) > half.x() - 0.3 || std::abs(p.y()) > half.y() - 0.3) continue;
    out.push_back({p, 0.25, false});
  }
  return out;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Position and heading error of `h` against the nearer of the true pose and its twin.
void errorsAgainst(const Pose2& truth, const Pose2& h, double& position, double& heading) {
  const Pose2 twin{-truth.x, -truth.y, geometry::normalizeAngle(truth.phi + kPi)};
  const double e1 = (h.position() - truth.position()).norm();
  const double e2 = (h.position() - twin.position()).norm();
  const Pose2& near = e1 <= e2 ? truth : twin;
  position = std::min(e1, e2);
  heading = std::abs(geometry::angleDiff(h.phi, near.phi));
}

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

int run(const Options& options) {
  region_tracking::SimCamera sim = region_tracking::SimCamera::load(options.camera, options.field);
  feature_recognition::FeatureRecognizer recognizer(sim.field);
  region_tracking::FrameProcessor processor(sim.mirror, sim.table,
                                            region_tracking::defaultVisionParams());
  region_tracking::VisionResult vision;
  perception::FieldFeatures features;

  if (!options.pose.empty()) {
    Pose2 pose;
    char c1 = 0, c2 = 0;
    std::istringstream in(options.pose);
    if (!(in >> pose.x >> c1 >> pose.y >> c2 >> pose.phi) || c1 != ',' || c2 != ',') {
      std::cerr << "--pose wants x,y,phi (m, m, rad)\n";
      return 2;
    }
    camera::SimScene scene;
    scene.robot = pose;
    for (int i = 0; i < 3; ++i) {
      scene.frame_number = static_cast<std::uint64_t>(i);
      processor.process(sim.render(scene), true, vision);
    }
    if (!options.dump.empty()) {
      std::ofstream out(options.dump);
      feature_recognition::writePointsCsv(out, vision.lines);
    }
    recognizer.recognize(vision.lines, features);
    for (const auto& h : features.hypotheses) {
      double position = 0, heading = 0;
      errorsAgainst(pose, h.pose, position, heading);
      std::cout << "kind=" << static_cast<int>(features.features[h.feature].kind)
                << " pose=" << h.pose.x << "," << h.pose.y << "," << h.pose.phi
                << " error_m=" << position << " error_deg=" << heading * 180 / kPi << "\n";
    }
    const auto& structure = recognizer.structure();
    for (int a = 0; a < 2; ++a) {
      for (const auto& g : structure.groups[a]) {
        std::cout << "group axis=" << a << " t=" << g.t << " length=" << g.line.length()
                  << " rms=" << g.line.rms << " start=" << g.line.start().transpose()
                  << " end=" << g.line.end().transpose() << "\n";
      }
    }
    const auto& contours = recognizer.contours();
    for (const auto& piece : contours.pieces) {
      const Vec2* p = contours.points.data() + piece.begin;
      const auto line = feature_recognition::fitLine(p, piece.size());
      std::cout << "piece n=" << piece.size()
                << " turn=" << feature_recognition::pieceTurn(p, piece.size())
                << " rms=" << line.rms << " length=" << line.length()
                << " from=" << p[0].transpose() << " to=" << p[piece.size() - 1].transpose()
                << "\n";
    }
    std::cout << "pieces=" << recognizer.contours().pieces.size()
              << " lines=" << recognizer.classified().lines.size()
              << " arcs=" << recognizer.classified().arcs.size()
              << " penalty=" << recognizer.penaltyFound()
              << " corners=" << recognizer.penalty().corners.size() << "\n";
    std::cout << "points=" << vision.lines.points.size()
              << " sequences=" << vision.lines.sequences.size()
              << " features=" << features.features.size() << "\n";
    return 0;
  }

  const std::vector<Pose2> path = scanPath(sim.field, options.frames);
  const std::vector<CornerSite> sites = cornerSites(sim.field);
  const double circle_radius = sim.field.dimensions().centre_circle_radius;
  std::mt19937 rng(options.seed);
  std::vector<FrameRecord> records;
  std::vector<double> position_errors, heading_errors;
  long false_hypotheses = 0, hypotheses = 0;
  long circle_eligible = 0, circle_found = 0, corner_eligible = 0, corner_found = 0;
  long frames_with_feature = 0;
  for (int f = 0; f < static_cast<int>(path.size()); ++f) {
    const Pose2& pose = path[f];
    camera::SimScene scene;
    scene.robot = pose;
    scene.frame_number = static_cast<std::uint64_t>(f);
    if (options.clutter) scene.robots = opponentsAround(pose, options.opponents, rng, sim.field);
    processor.process(sim.render(scene), true, vision);
    recognizer.recognize(vision.lines, features);

    FrameRecord record;
    record.position = pose.position();
    bool correct_circle = false;
    for (const auto& h : features.hypotheses) {
      ++hypotheses;
      double position = 0, heading = 0;
      errorsAgainst(pose, h.pose, position, heading);
      if (position > kFalseDistance || heading > kFalseAngle) {
        ++false_hypotheses;
        record.false_hypothesis = true;
        std::cerr << "false hypothesis: frame " << f << " pose " << pose.x << "," << pose.y << ","
                  << pose.phi << " kind " << static_cast<int>(features.features[h.feature].kind)
                  << " error " << position << " m " << heading * 180 / kPi << " deg\n";
        continue;
      }
      position_errors.push_back(position);
      heading_errors.push_back(heading * 180 / kPi);
      if (features.features[h.feature].kind == FeatureKind::kCentreCircle) correct_circle = true;
    }
    if (!features.hypotheses.empty()) ++frames_with_feature;
    record.detected[kCircle] = correct_circle;
    if (pose.position().norm() + circle_radius <= kViewDistance) {
      ++circle_eligible;
      if (correct_circle) ++circle_found;
    }
    for (const CornerSite& site : sites) {
      bool found = false;
      for (const auto& feature : features.features) {
        if (feature.kind != FeatureKind::kPenaltyCorner) continue;
        const Vec2 seen = geometry::pointRobotToField(pose, {feature.local.x, feature.local.y});
        if ((seen - site.position).norm() <= kFalseDistance) found = true;
      }
      if (found) {
        record.detected[site.inner ? (site.left ? kLeftInner : kRightInner)
                                   : (site.left ? kLeftOuter : kRightOuter)] = true;
      }
      if ((site.position - pose.position()).norm() <= kViewDistance) {
        ++corner_eligible;
        if (found) ++corner_found;
      }
    }
    records.push_back(record);
  }

  const double circle_rate = circle_eligible ? double(circle_found) / circle_eligible : 0.0;
  const double corner_rate = corner_eligible ? double(corner_found) / corner_eligible : 0.0;
  const double pos_median = median(position_errors);
  const double heading_median = median(heading_errors);

  if (!options.out_dir.empty()) {
    std::filesystem::create_directories(options.out_dir);
    for (int k = 0; k < kMapKinds; ++k) {
      MapCanvas canvas(sim.field, 30.0);
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
      cv::putText(canvas.image, kMapNames[k], {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6,
                  {255, 255, 255}, 1, cv::LINE_AA);
      cv::imwrite(options.out_dir + "/detection_" + kMapNames[k] + ".png", canvas.image);
    }
    std::ofstream json(options.out_dir + "/summary.json");
    json << "{\n  \"frames\": " << records.size() << ",\n  \"field\": \"" << options.field
         << "\",\n  \"clutter\": " << (options.clutter ? "true" : "false")
         << ",\n  \"hypotheses\": " << hypotheses
         << ",\n  \"false_hypotheses\": " << false_hypotheses
         << ",\n  \"frames_with_hypotheses\": " << frames_with_feature
         << ",\n  \"circle_eligible_frames\": " << circle_eligible
         << ",\n  \"circle_found\": " << circle_found << ",\n  \"circle_rate\": " << circle_rate
         << ",\n  \"corner_eligible\": " << corner_eligible
         << ",\n  \"corner_found\": " << corner_found << ",\n  \"corner_rate\": " << corner_rate
         << ",\n  \"pos_median_m\": " << pos_median
         << ",\n  \"heading_median_deg\": " << heading_median << "\n}\n";
  }

  std::cout << "frames=" << records.size() << " false_hypotheses=" << false_hypotheses
            << " circle_rate=" << circle_rate << " corner_rate=" << corner_rate
            << " pos_median_m=" << pos_median << " heading_median_deg=" << heading_median
            << std::endl;
  bool ok = false_hypotheses == 0;
  if (options.min_circle_rate >= 0 && circle_rate < options.min_circle_rate) ok = false;
  if (options.min_corner_rate >= 0 && corner_rate < options.min_corner_rate) ok = false;
  return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Evaluates feature recognition on rendered frames over the whole field: detection rates, "
      "false pose hypotheses and pose errors. Exit code 1 when a hypothesis is false or a "
      "required rate is missed."};
  Options options;
  app.add_option("--frames", options.frames, "Frames along the scanning path")
      ->check(CLI::Range(1, 10'000'000))
      ->capture_default_str();
  app.add_option("--field", options.field, "Field preset or YAML file")->capture_default_str();
  app.add_option("--camera", options.camera, "Camera preset")->capture_default_str();
  app.add_flag("!--no-clutter", options.clutter, "No opponents or clutter");
  app.add_option("--opponents", options.opponents, "Opponents around the robot per frame")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Seed of the clutter placement")->capture_default_str();
  app.add_option("--out", options.out_dir, "Directory for the detection maps and summary.json");
  app.add_option("--min-circle-rate", options.min_circle_rate,
                 "Fail (exit 1) below this centre circle rate")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--min-corner-rate", options.min_corner_rate,
                 "Fail (exit 1) below this penalty corner rate")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--pose", options.pose,
                 "Evaluate one frame at x,y,phi (m, m, rad) and print its hypotheses");
  app.add_option("--dump", options.dump, "With --pose: write the frame's line points as CSV");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help exits 0; bad arguments exit 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    return run(options);
  } catch (const std::exception& e) {
    std::cerr << "fieldline-eval-features: " << e.what() << "\n";
    return 2;
  }
}
