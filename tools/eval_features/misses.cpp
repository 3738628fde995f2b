// What the camera of fieldline-eval-features could see: blocked rays, occluded shares of the
// centre circle, why a penalty corner within 4 m was missed, and the occlusion series.
#include "tools/eval_features/frame_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace fieldline::eval_features {

// True if the ray from the camera (at the mirror's reference height above the robot) to the floor
// point `q` (field frame) passes through a robot's cylinder.
bool rayBlocked(const camera::SimScene& scene, const Vec2& q, double camera_height,
                double robot_height) {
  const Vec2 p = scene.robot.position();
  const Vec2 d = q - p;
  for (const auto& robot : scene.robots) {
    // |p + t d - c| = rho for t in [t0, t1]; the ray is below the robot's top for
    // t >= 1 - robot_height / camera_height.
    const Vec2 f = p - robot.position;
    const double A = d.squaredNorm(), B = 2 * f.dot(d),
                 C = f.squaredNorm() - robot.radius * robot.radius;
    const double disc = B * B - 4 * A * C;
    if (disc < 0 || A <= 0) continue;
    const double t0 = (-B - std::sqrt(disc)) / (2 * A), t1 = (-B + std::sqrt(disc)) / (2 * A);
    const double low = std::max(t0, 1.0 - robot_height / camera_height);
    if (t1 >= low && low <= 1.0 && t1 >= 0.0) return true;
  }
  return false;
}

// Share of the centre circle hidden from the camera by the robots in `scene`: the circle sampled
// every degree, a sample hidden when the ray from the camera to it is blocked.
double occludedCircleShare(const camera::SimScene& scene, double radius, double camera_height,
                           double robot_height) {
  const int samples = 360;
  int hidden = 0;
  for (int k = 0; k < samples; ++k) {
    const double a = 2 * kPi * k / samples;
    if (rayBlocked(scene, radius * Vec2(std::cos(a), std::sin(a)), camera_height, robot_height)) {
      ++hidden;
    }
  }
  return static_cast<double>(hidden) / samples;
}

constexpr double kLegReach = 0.75;

// The visibility part of the diagnosis (zone, blocked, front_visible, side_visible).
void cornerVisibility(const CornerSite& site, const Pose2& pose, const camera::SimScene& scene,
                      const region_tracking::SimCamera& sim, MissDiagnosis& m) {
  const auto& d = sim.field.dimensions();
  const double camera_height = sim.mirror.params().reference_height;
  const double robot_height = sim.renderer->params().robot_height;
  const Vec2 corner = site.position;
  const double sx = corner.x() > 0 ? 1.0 : -1.0, sy = corner.y() > 0 ? 1.0 : -1.0;
  const Vec2 front_dir(0.0, -sy), side_dir(sx, 0.0);
  const double side_length =
      std::min(kLegReach, site.inner ? d.goal_area_depth : d.penalty_area_depth);
  auto zoneOf = [&](const Vec2& field_point) {
    const Vec2 local = geometry::pointFieldToRobot(pose, field_point);
    const auto pixel = sim.mirror.robotToImage(local);
    if (!pixel) return local.norm() < 1.0 ? 1 : 2;
    const camera::MirrorZone z = sim.mirror.zone(*pixel);
    return z == camera::MirrorZone::kUseful ? 0 : z == camera::MirrorZone::kSelf ? 1 : 2;
  };
  m.zone = zoneOf(corner);
  m.blocked = rayBlocked(scene, corner, camera_height, robot_height);
  auto visibleShare = [&](const Vec2& dir, double length) {
    int seen = 0, n = 0;
    for (double t = 0.05; t <= length + 1e-9; t += 0.05, ++n) {
      const Vec2 q = corner + t * dir;
      if (zoneOf(q) == 0 && !rayBlocked(scene, q, camera_height, robot_height)) ++seen;
    }
    return n ? static_cast<double>(seen) / n : 0.0;
  };
  m.front_visible = visibleShare(front_dir, kLegReach);
  m.side_visible = visibleShare(side_dir, side_length);
}

// A corner the camera can see: its point in the useful part of the image, no robot in the way,
// and at least half of the first 0.75 m of both its lines visible likewise.
bool seeable(const MissDiagnosis& m) {
  return m.zone == 0 && !m.blocked && m.front_visible >= 0.5 && m.side_visible >= 0.5;
}

MissDiagnosis diagnoseMiss(const CornerSite& site, const Pose2& pose, const camera::SimScene& scene,
                           const region_tracking::SimCamera& sim,
                           const perception::LinePoints& lines,
                           const feature_recognition::FeatureRecognizer& recognizer) {
  MissDiagnosis m;
  cornerVisibility(site, pose, scene, sim, m);
  const auto& d = sim.field.dimensions();
  const Vec2 corner = site.position;
  const double sx = corner.x() > 0 ? 1.0 : -1.0, sy = corner.y() > 0 ? 1.0 : -1.0;
  const Vec2 front_dir(0.0, -sy), side_dir(sx, 0.0);
  const double side_length =
      std::min(kLegReach, site.inner ? d.goal_area_depth : d.penalty_area_depth);
  const Vec2 local_corner = geometry::pointFieldToRobot(pose, corner);
  const Vec2 local_front = geometry::rotate(front_dir, -pose.phi);
  const Vec2 local_side = geometry::rotate(side_dir, -pose.phi);
  auto onLeg = [&](const Vec2& p, const Vec2& dir, double length) {
    // Away from both ends (the points of the perpendicular lines there are not the leg's).
    const double t = (p - local_corner).dot(dir);
    if (t < 0.1 || t > length - 0.1) return false;
    return (p - local_corner - t * dir).norm() <= 0.12;
  };
  for (const auto& p : lines.points) {
    const Vec2 q(p.x, p.y);
    if (onLeg(q, local_front, kLegReach)) ++m.front_points;
    if (onLeg(q, local_side, side_length)) ++m.side_points;
  }
  const auto& structure = recognizer.structure();
  for (const auto& groups : structure.groups) {
    for (const auto& g : groups) {
      const auto& line = g.line;
      auto along = [&](const Vec2& dir) {
        if (std::abs(line.direction.dot(dir)) < std::cos(0.3)) return false;
        if (std::abs(line.signedDistance(local_corner)) > 0.2) return false;
        // The group's extent reaches within 0.5 m of the corner on the leg's side.
        const double a = (line.start() - local_corner).dot(dir);
        const double b = (line.end() - local_corner).dot(dir);
        return std::max(a, b) > 0.1 && std::min(a, b) < 0.5;
      };
      if (along(local_front)) m.front_group = true;
      if (along(local_side)) m.side_group = true;
    }
  }
  for (const auto& j : recognizer.junctions()) {
    if ((j.position - local_corner).norm() <= 0.4) m.junction = true;
  }
  if (recognizer.penaltyFound()) {
    for (const auto& c : recognizer.penalty().corners) {
      if ((c.position - local_corner).norm() <= 0.4) m.structure_corner = true;
    }
  }
  for (const auto& c : recognizer.checked()) {
    if (c.kind != FeatureKind::kPenaltyCorner) continue;
    if ((Vec2(c.local.x, c.local.y) - local_corner).norm() <= 0.4) m.checked = true;
  }
  const int min_points = recognizer.params().min_corner_line_points;
  if (m.zone == 1) {
    m.cause = "self_reflection";
  } else if (m.zone == 2) {
    m.cause = "beyond_view";
  } else if (m.blocked) {
    m.cause = "occluded";
  } else if (m.front_visible < 0.5 || m.side_visible < 0.5) {
    m.cause = "leg_hidden";
  } else if (m.front_points < min_points || m.side_points < min_points) {
    m.cause = "few_points";
  } else if (!m.front_group || !m.side_group) {
    m.cause = "no_line_group";
  } else if (!m.junction && !m.structure_corner) {
    m.cause = "no_junction";
  } else if (m.checked) {
    m.cause = "refused";
  } else {
    m.cause = "not_identified";
  }
  return m;
}
// Seed fig. 4.60: the robot within reach of the whole centre circle, 0-10 robots standing on and
// around the circle; the centre circle detection rate per occluded share (bins of 10 %).
void occlusionSeries(const Options& options, region_tracking::SimCamera& sim,
                     region_tracking::FrameProcessor& processor,
                     feature_recognition::FeatureRecognizer& recognizer) {
  const double radius = sim.field.dimensions().centre_circle_radius;
  const double camera_height = sim.mirror.params().reference_height;
  const double robot_height = sim.renderer->params().robot_height;
  constexpr int kBins = 10;
  long frames[kBins] = {}, found[kBins] = {};
  long false_hypotheses = 0;
  region_tracking::VisionResult vision;
  perception::FieldFeatures features;
  for (int f = 0; f < options.occlusion_frames; ++f) {
    std::mt19937 rng = frameRng(options.seed, static_cast<std::uint64_t>(f), 1);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double reach = std::max(0.0, kViewDistance - radius);
    const double rr = reach * std::sqrt(unit(rng)), ra = 2 * kPi * unit(rng);
    camera::SimScene scene;
    scene.robot = {rr * std::cos(ra), rr * std::sin(ra), 2 * kPi * unit(rng) - kPi};
    scene.frame_number = 1'000'000'000ULL + static_cast<std::uint64_t>(f);
    const int obstacles = static_cast<int>(unit(rng) * 11);
    for (int i = 0; i < obstacles; ++i) {
      const double a = 2 * kPi * unit(rng);
      const Vec2 c = (radius + 1.0 * (unit(rng) - 0.5)) * Vec2(std::cos(a), std::sin(a));
      if ((c - scene.robot.position()).norm() < 0.8) continue;
      scene.robots.push_back({c, 0.25, false, {}, {}});
    }
    const double share = occludedCircleShare(scene, radius, camera_height, robot_height);
    visionOf(sim, processor, scene, vision);
    recognizer.recognize(vision.lines, features);
    bool correct = false;
    for (const auto& h : features.hypotheses) {
      double position = 0, heading = 0;
      errorsAgainst(scene.robot, h.pose, position, heading);
      if (position > kFalseDistance || heading > kFalseAngle) {
        ++false_hypotheses;
      } else if (features.features[h.feature].kind == FeatureKind::kCentreCircle) {
        correct = true;
      }
    }
    const int bin = std::min(kBins - 1, static_cast<int>(share * kBins));
    ++frames[bin];
    if (correct) ++found[bin];
  }
  std::ostringstream json;
  json << "{\n  \"frames\": " << options.occlusion_frames
       << ",\n  \"false_hypotheses\": " << false_hypotheses << ",\n  \"bins\": [";
  for (int b = 0; b < kBins; ++b) {
    json << (b ? ",\n" : "\n") << "    {\"occluded_from\": " << b / double(kBins)
         << ", \"occluded_to\": " << (b + 1) / double(kBins) << ", \"frames\": " << frames[b]
         << ", \"circle_found\": " << found[b]
         << ", \"rate\": " << (frames[b] ? double(found[b]) / frames[b] : 0.0) << "}";
    std::cout << "occlusion " << b * 10 << "-" << (b + 1) * 10 << "% frames=" << frames[b]
              << " circle_rate=" << (frames[b] ? double(found[b]) / frames[b] : 0.0) << "\n";
  }
  json << "\n  ]\n}\n";
  std::cout << "occlusion_false_hypotheses=" << false_hypotheses << "\n";
  if (options.output.out_dir.empty()) return;
  std::filesystem::create_directories(options.output.out_dir);
  std::ofstream(options.output.out_dir + "/occlusion.json") << json.str();
  // Bar chart: rate per bin, the number of frames under each bar.
  const int w = 560, h = 300, left = 50, bottom = 250, bar = 45;
  cv::Mat chart(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::line(chart, {left, bottom}, {left + kBins * (bar + 5), bottom}, {0, 0, 0});
  cv::line(chart, {left, bottom}, {left, 30}, {0, 0, 0});
  for (int b = 0; b < kBins; ++b) {
    const double rate = frames[b] ? double(found[b]) / frames[b] : 0.0;
    const int x0 = left + 5 + b * (bar + 5);
    cv::rectangle(chart, {x0, bottom - static_cast<int>(rate * 200)}, {x0 + bar, bottom},
                  {200, 120, 40}, -1);
    cv::putText(chart, std::to_string(b * 10) + "%", {x0 + 8, bottom + 16},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1, cv::LINE_AA);
    cv::putText(chart, "n=" + std::to_string(frames[b]), {x0 + 2, bottom + 32},
                cv::FONT_HERSHEY_SIMPLEX, 0.35, {80, 80, 80}, 1, cv::LINE_AA);
  }
  for (int k = 0; k <= 4; ++k) {
    cv::putText(chart, std::to_string(k * 25) + "%", {8, bottom - k * 50 + 4},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1, cv::LINE_AA);
  }
  cv::putText(chart, "centre circle found vs share of the circle occluded", {left, 20},
              cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  cv::imwrite(options.output.out_dir + "/occlusion.png", chart);
}

}  // namespace fieldline::eval_features
