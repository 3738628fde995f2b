#include "tools/sim_frames/sim_frames.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/config/config.hpp"
#include "common/msg/image.hpp"

namespace fieldline::region_tracking {

SimCamera SimCamera::load(const std::string& cameraPreset, const std::string& fieldPreset) {
  const config::Node root = config::Node::loadFile(config::resolvePreset("camera", cameraPreset));
  camera::CameraModel model = camera::loadCameraModel(root);
  field::FieldModel field = field::loadFieldPreset(fieldPreset);
  camera::ColourTable table = camera::loadColourTablePreset(model.colour_table);
  const camera::RenderParams render = camera::loadRenderParams(root.child("render"));
  auto renderer = std::make_unique<camera::SimRenderer>(model.mirror, field, render);
  return SimCamera{model.mirror, std::move(table), std::move(field), std::move(renderer), {}};
}

image_t SimCamera::renderImage(const camera::SimScene& scene, Utime exposure_utime) {
  render(scene);
  image_t image{};
  image.header.utime = exposure_utime;
  msg::toMessage(renderer->view(frame), image);
  image.source = image_t::SOURCE_SIM;
  image.frame_number = static_cast<std::int64_t>(scene.frame_number);
  return image;
}

camera::SimBox standingBox(const geometry::Vec2& centre, double sx, double sy, double height,
                           camera::Bgr colour) {
  camera::SimBox b;
  b.lo = Eigen::Vector3d(centre.x() - sx / 2, centre.y() - sy / 2, 0.0);
  b.hi = Eigen::Vector3d(centre.x() + sx / 2, centre.y() + sy / 2, height);
  b.colour = colour;
  return b;
}

geometry::Vec2 placeBeyondLines(const field::FieldModel& field, std::mt19937& rng, bool side_only) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const geometry::Vec2 half = field.carpetHalfExtent();
  const geometry::Vec2 lines(field.length() / 2, field.width() / 2);
  const bool along_x = side_only || unit(rng) < 0.6;
  const double sign = unit(rng) < 0.5 ? -1.0 : 1.0;
  // y is drawn before x: the order the evaluations' recorded figures were measured with.
  if (along_x) {
    const double y = sign * uniform(lines.y() + 0.4, half.y() + 1.5);
    return {uniform(-half.x(), half.x()), y};
  }
  const double y = uniform(-half.y(), half.y());
  return {sign * uniform(lines.x() + 0.4, half.x() + 1.5), y};
}

std::vector<geometry::Pose2> motionPoses(const field::FieldModel& field, const Motion& motion,
                                         int frames) {
  // A circuit 1.5 m inside the field lines (at least halfway in on a small field), with
  // rounded corners.
  const double a = std::max(field.length() / 2 - 1.5, field.length() / 4);
  const double b = std::max(field.width() / 2 - 1.5, field.width() / 4);
  const double corner = std::min(1.0, 0.5 * std::min(a, b));
  const double straightX = 2 * (a - corner), straightY = 2 * (b - corner);
  const double arc = std::numbers::pi / 2 * corner;
  const double perimeter = 2 * straightX + 2 * straightY + 4 * arc;
  auto pointAt = [&](double s) -> Eigen::Vector2d {
    s = std::fmod(s, perimeter);
    // Bottom edge left to right, then around counter-clockwise.
    const double legs[8] = {straightX, arc, straightY, arc, straightX, arc, straightY, arc};
    const Eigen::Vector2d starts[4] = {
        {-a + corner, -b}, {a, -b + corner}, {a - corner, b}, {-a, b - corner}};
    const Eigen::Vector2d dirs[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
    for (int leg = 0; leg < 8; ++leg) {
      if (s <= legs[leg] || leg == 7) {
        const int side = leg / 2;
        if (leg % 2 == 0) return starts[side] + dirs[side] * s;
        // Arc around the corner centre, turning from dirs[side] to dirs[side + 1].
        const Eigen::Vector2d end =
            starts[side] + dirs[side] * (leg / 2 % 2 ? straightY : straightX);
        const Eigen::Vector2d next = dirs[(side + 1) % 4];
        const Eigen::Vector2d centre = end + next * corner;
        const double angle = s / corner;
        return centre - next * corner * std::cos(angle) + dirs[side] * corner * std::sin(angle);
      }
      s -= legs[leg];
    }
    return Eigen::Vector2d::Zero();
  };
  std::vector<geometry::Pose2> poses;
  poses.reserve(frames);
  for (int i = 0; i < frames; ++i) {
    const double t = i / motion.frame_rate;
    const Eigen::Vector2d p = pointAt(motion.speed * t);
    poses.push_back({p.x(), p.y(), std::remainder(0.3 + motion.omega * t, 2 * std::numbers::pi)});
  }
  return poses;
}

}  // namespace fieldline::region_tracking
