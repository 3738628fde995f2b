// The scene of each frame of fieldline-eval-features: the scanning path, the corners, the clutter.
#include "tools/eval_features/frame_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

namespace fieldline::eval_features {

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

// Per-frame random numbers: frame f of seed s is the same whatever frames ran before it.
std::mt19937 frameRng(std::uint32_t seed, std::uint64_t frame, std::uint32_t stream) {
  std::seed_seq seq{seed, static_cast<std::uint32_t>(frame),
                    static_cast<std::uint32_t>(frame >> 32), stream};
  return std::mt19937(seq);
}

const camera::Bgr kWhite{225, 230, 230};
const camera::Bgr kOrange{10, 100, 240};
// Third-team markers and clothes: red, blue, yellow, dark grey, a light shirt.
const camera::Bgr kColours[] = {
    {40, 40, 200}, {200, 90, 30}, {30, 200, 220}, {60, 60, 60}, {200, 205, 205}};

// The robot's scene in frame `frame`: opponents within 1-5 m (some white, some of a third team's
// colour), white objects beyond the border lines, people beyond the side lines, flat white
// patches on the carpet and orange objects. Deterministic per (seed, frame).
camera::SimScene sceneFor(const Pose2& pose, std::uint64_t frame, const Options& o,
                          const field::FieldModel& field) {
  camera::SimScene scene;
  scene.robot = pose;
  scene.frame_number = frame;
  if (!o.scene.clutter) return scene;
  std::mt19937 rng = frameRng(o.seed, frame, 0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const Vec2 half = field.carpetHalfExtent();
  for (int i = 0; i < o.scene.opponents; ++i) {
    const double d = uniform(1.0, 5.0), b = uniform(-kPi, kPi);
    const Vec2 p = pose.position() + d * Vec2(std::cos(b), std::sin(b));
    const double kind = unit(rng);
    const camera::Bgr colour = kColours[static_cast<int>(unit(rng) * 4.999)];
    if (std::abs(p.x()) > half.x() - 0.3 || std::abs(p.y()) > half.y() - 0.3) continue;
    camera::SimRobot r{p, 0.25, false, {}, {}};
    if (kind < o.scene.white_robot_share) {
      r.body_colour = kWhite;
    } else if (kind < o.scene.white_robot_share + o.scene.other_colour_share) {
      r.marker_colour = colour;
    }
    scene.robots.push_back(r);
  }
  using region_tracking::standingBox;
  // Where hall clutter stands: beyond the field's lines.
  auto beyondBorder = [&](bool side_only) {
    return region_tracking::placeBeyondLines(field, rng, side_only);
  };
  for (int i = 0; i < o.scene.white_objects; ++i) {
    const Vec2 c = beyondBorder(false);
    const double sx = uniform(0.2, 1.0), sy = uniform(0.2, 1.0), h = uniform(0.2, 1.2);
    scene.boxes.push_back(standingBox(c, sx, sy, h, kWhite));
  }
  for (int i = 0; i < o.scene.people; ++i) {
    const Vec2 c = beyondBorder(true);
    const camera::Bgr colour = kColours[static_cast<int>(unit(rng) * 4.999)];
    scene.boxes.push_back(standingBox(c, 0.45, 0.3, uniform(1.5, 1.9), colour));
  }
  for (int i = 0; i < o.scene.patches; ++i) {
    const double d = uniform(0.8, 5.0), b = uniform(-kPi, kPi);
    const Vec2 c = pose.position() + d * Vec2(std::cos(b), std::sin(b));
    scene.boxes.push_back(standingBox(c, uniform(0.05, 0.3), uniform(0.05, 0.3), 0.004, kWhite));
  }
  for (int i = 0; i < o.scene.orange_objects; ++i) {
    const double d = uniform(0.8, 5.0), b = uniform(-kPi, kPi);
    scene.ball = camera::SimBall{pose.position() + d * Vec2(std::cos(b), std::sin(b)), 0.11};
    scene.boxes.push_back(standingBox(beyondBorder(false), uniform(0.2, 0.6), uniform(0.2, 0.6),
                                      uniform(0.1, 0.8), kOrange));
  }
  return scene;
}

}  // namespace fieldline::eval_features
