#include "tools/eval_ball/ball_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>

#include <fmt/format.h>

namespace fieldline::eval_ball {

namespace {

using camera::Vec2;
constexpr double kPi = std::numbers::pi;
// The ball's colour (as the renderer draws it) and a red shirt.
const camera::Bgr kOrange{10, 100, 240};
const camera::Bgr kRed{40, 40, 200};
// Balls nearer than this hide under the robot's own reflection (0.28 m of floor) and body.
constexpr double kNearestVisible = 0.4;

std::mt19937 segmentRng(std::uint32_t seed, int segment) {
  std::seed_seq seq{seed, static_cast<std::uint32_t>(segment + 1), 0xba11u};
  return std::mt19937(seq);
}

// Whether the whole image of a ball at `ball` (robot frame) lies inside the frame.
bool wholeInImage(const camera::MirrorModel& mirror, const Vec2& ball, double radius) {
  for (int i = 0; i <= 6; ++i) {
    const double theta = kPi * i / 6;
    for (int j = 0; j < 12; ++j) {
      const double phi = 2 * kPi * j / 12;
      const camera::Vec3 p(ball.x() + radius * std::sin(theta) * std::cos(phi),
                           ball.y() + radius * std::sin(theta) * std::sin(phi),
                           radius * (1 + std::cos(theta)));
      const std::optional<Vec2> pixel = mirror.robotPointToImage(p);
      if (!pixel || pixel->x() < 0 || pixel->y() < 0 || pixel->x() > mirror.width() - 1 ||
          pixel->y() > mirror.height() - 1) {
        return false;
      }
    }
  }
  return true;
}

// Why the ball of a frame was missed: no candidate, or the reasons its candidates were refused.
void countMiss(region_tracking::FrameProcessor& processor, const camera::FrameView& frame,
               const region_tracking::BallRegion* region, BallEvalResult& result) {
  const region_tracking::ContourSet& contours = processor.tracker().contours();
  const region_tracking::ClassId orange = region_tracking::classIdOf(camera::ColourClass::kOrange);
  region_tracking::BallDetection detection;
  int candidates = 0;
  for (const region_tracking::Contour& c : contours.contours) {
    if (c.class_id != orange || !c.outer) continue;
    ++candidates;
    const auto reason = processor.ballDetector().evaluate(frame, contours, c, detection, region);
    ++result.missed_reasons[static_cast<std::size_t>(reason)];
  }
  if (candidates == 0) ++result.missed_without_candidate;
}

}  // namespace

double BallEvalResult::errorQuantile(double q) const {
  if (errors.empty()) return 0.0;
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t i = static_cast<std::size_t>(std::ceil(q * sorted.size())) - 1;
  return sorted[std::min(i, sorted.size() - 1)];
}

std::vector<Vec2> ballPath(const BallEvalOptions& o, const field::FieldModel& field,
                           const std::vector<geometry::Pose2>& poses) {
  constexpr double kFrameRate = 30.0;
  const int frames = static_cast<int>(poses.size());
  const Vec2 inside(field.length() / 2 - 0.15, field.width() / 2 - 0.15);
  std::mt19937 rng = segmentRng(o.seed, -1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Vec2 p(inside.x() * (2 * unit(rng) - 1), inside.y() * (2 * unit(rng) - 1));
  Vec2 velocity = Vec2::Zero();
  std::vector<Vec2> path;
  path.reserve(poses.size());
  for (int i = 0; i < frames; ++i) {
    if (i % o.segment_frames == 0) {
      std::mt19937 segment = segmentRng(o.seed, i / o.segment_frames);
      const int end = std::min(frames - 1, i + o.segment_frames);
      const double d = 0.5 + 5.0 * unit(segment), b = kPi * (2 * unit(segment) - 1);
      const Vec2 target =
          poses[static_cast<std::size_t>(end)].position() + d * Vec2(std::cos(b), std::sin(b));
      velocity = (target - p) * (kFrameRate / o.segment_frames);
      if (velocity.norm() > o.max_ball_speed) velocity *= o.max_ball_speed / velocity.norm();
    }
    path.push_back(p);
    p += velocity / kFrameRate;
    for (int axis = 0; axis < 2; ++axis) {  // bounce off the lines
      if (std::abs(p[axis]) > inside[axis]) {
        p[axis] = std::copysign(2 * inside[axis] - std::abs(p[axis]), p[axis]);
        velocity[axis] = -velocity[axis];
      }
    }
  }
  return path;
}

camera::SimScene sceneFor(const BallEvalOptions& o, const field::FieldModel& field,
                          const std::vector<geometry::Pose2>& poses, const std::vector<Vec2>& balls,
                          int frame) {
  camera::SimScene scene;
  scene.robot = poses.at(static_cast<std::size_t>(frame));
  scene.frame_number = static_cast<std::uint64_t>(frame);
  scene.ball = camera::SimBall{balls.at(static_cast<std::size_t>(frame)), 0.11};
  const int segment = frame / o.segment_frames;
  std::mt19937 rng = segmentRng(o.seed + 1, segment);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  using region_tracking::placeBeyondLines;
  using region_tracking::standingBox;
  // Orange things in the hall (bags, jackets, boxes, cones): larger than a ball.
  for (int i = 0; i < o.orange_objects; ++i) {
    scene.boxes.push_back(standingBox(placeBeyondLines(field, rng, false), uniform(0.3, 0.8),
                                      uniform(0.3, 0.8), uniform(0.3, 1.0), kOrange));
  }
  // People in red beyond the side lines.
  for (int i = 0; i < o.people; ++i) {
    scene.boxes.push_back(
        standingBox(placeBeyondLines(field, rng, true), 0.45, 0.3, uniform(1.5, 1.9), kRed));
  }
  return scene;
}

BallEvalResult evaluateBall(region_tracking::SimCamera& sim,
                            const region_tracking::VisionParams& vision, const BallEvalOptions& o) {
  if (o.frames < 1 || o.segment_frames < 1) {
    throw std::invalid_argument("ball evaluation: frames and segment_frames must be positive");
  }
  const std::vector<geometry::Pose2> poses = region_tracking::motionPoses(
      sim.field, region_tracking::Motion{.speed = 1.0, .omega = 0.4}, o.frames);
  const std::vector<Vec2> balls = ballPath(o, sim.field, poses);
  sim.renderer->realism().setParams(o.realism);
  const camera::ColourTable& table = o.table ? *o.table : sim.table;
  region_tracking::FrameProcessor processor(sim.mirror, table, vision);
  region_tracking::VisionResult out;
  BallEvalResult result;
  std::mt19937 pose_rng(o.seed + 7);
  std::normal_distribution<double> pose_error(0.0, 1.0);
  std::optional<region_tracking::BallRegion> region;
  for (int i = 0; i < o.frames; ++i) {
    const camera::SimScene scene = sceneFor(o, sim.field, poses, balls, i);
    if (o.field_check) {
      // Fusion's pose: the truth, off by its uncertainty.
      const geometry::Pose2 pose{scene.robot.x + o.pose_sigma_m * pose_error(pose_rng),
                                 scene.robot.y + o.pose_sigma_m * pose_error(pose_rng),
                                 scene.robot.phi + 0.1 * o.pose_sigma_m * pose_error(pose_rng)};
      region = region_tracking::BallRegion{&sim.field, pose, o.pose_sigma_m};
    }
    processor.setBallRegion(region);
    processor.process(sim.render(scene), i % 3 == 0, out);
    ++result.frames;
    result.candidates += out.ball.candidates;
    result.rejected += out.ball.rejected;
    double truthDistance = -1.0;
    Vec2 truth = Vec2::Zero();
    if (scene.ball) {
      truth = geometry::pointFieldToRobot(scene.robot, scene.ball->position);
      truthDistance = truth.norm();
    }
    const bool inReach = truthDistance >= kNearestVisible && truthDistance <= o.visible_within;
    const bool whole = inReach && wholeInImage(sim.mirror, truth, scene.ball->radius);
    const bool visible = inReach && whole;
    if (inReach && !whole) ++result.cut_frames;
    const int metre = std::clamp(static_cast<int>(truthDistance), 0, 3);
    if (visible) {
      ++result.visible_frames;
      ++result.visible_by_metre[metre];
    }
    if (!out.ball.visible) {
      if (visible) {
        countMiss(processor, sim.renderer->view(sim.frame), region ? &*region : nullptr, result);
      }
      continue;
    }
    const Vec2 reported = geometry::pointRobotToField(scene.robot, Vec2(out.ball.x, out.ball.y));
    if (!sim.field.insideLines(reported)) ++result.outside_field;
    const double error = scene.ball ? (Vec2(out.ball.x, out.ball.y) - truth).norm() : -1.0;
    if (!scene.ball || error > o.false_ball_distance) {
      ++result.false_balls;
      if (result.first_false.size() < 10) {
        result.first_false.push_back({i, out.ball.x, out.ball.y, truthDistance});
      }
      continue;
    }
    if (inReach && !whole) ++result.cut_found;
    if (visible) {
      ++result.found_frames;
      ++result.found_by_metre[metre];
      result.errors.push_back(error);
      if (error <= 0.05) ++result.within_5cm;
    }
  }
  sim.renderer->realism().setParams({});
  return result;
}

std::string summaryLine(const BallEvalResult& r) {
  return fmt::format(
      "frames={} false_balls={} outside_field={} found_rate={:.4f} err_median_m={:.4f} "
      "err_p95_m={:.4f} visible_frames={} within_5cm_rate={:.4f} cut_frames={} cut_found={} "
      "candidates={} rejected={}",
      r.frames, r.false_balls, r.outside_field, r.foundRate(), r.errorQuantile(0.5),
      r.errorQuantile(0.95), r.visible_frames,
      r.visible_frames > 0 ? static_cast<double>(r.within_5cm) / r.visible_frames : 0.0,
      r.cut_frames, r.cut_found, r.candidates, r.rejected);
}

}  // namespace fieldline::eval_ball

namespace fieldline::eval_ball {

std::string missLine(const BallEvalResult& r) {
  std::string line = "found_by_distance:";
  for (int m = 0; m < 4; ++m) {
    line += fmt::format(" {}-{}m={}/{}", m, m + 1, r.found_by_metre[m], r.visible_by_metre[m]);
  }
  const char* names[] = {"none", "too_few_pixels", "too_large",     "at_image_border", "no_floor",
                         "size", "fill",           "not_on_carpet", "outside_field"};
  static_assert(std::size(names) == region_tracking::kBallRejectCount);
  line += fmt::format(" missed_without_candidate={} refused:", r.missed_without_candidate);
  for (std::size_t i = 1; i < r.missed_reasons.size(); ++i) {
    line += fmt::format(" {}={}", names[i], r.missed_reasons[i]);
  }
  return line;
}

}  // namespace fieldline::eval_ball
