#include "tools/mirror_calibrate/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace fieldline::calibration {

GreyImage renderRingCarpet(const camera::MirrorModel& mirror, const RingCarpet& carpet,
                           const camera::RealismParams& realism, std::uint64_t frame_number) {
  if (carpet.supersample < 1 || !(carpet.ring_width > 0.0)) {
    throw std::invalid_argument("ring carpet: supersample >= 1 and ring_width > 0 expected");
  }
  const int w = mirror.width();
  const int h = mirror.height();
  const camera::MirrorParams& m = mirror.params();
  std::vector<camera::Yuv> frame(static_cast<std::size_t>(w) * h, camera::Yuv{10, 128, 128});
  const int s = carpet.supersample;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const double r = mirror.radiusOf(camera::Vec2(u, v));
      if (r > m.outer_radius + 1.0) continue;
      double sum = 0.0;
      for (int j = 0; j < s; ++j) {
        for (int i = 0; i < s; ++i) {
          const camera::Vec2 px(u - 0.5 + (i + 0.5) / s, v - 0.5 + (j + 0.5) / s);
          const double rr = mirror.radiusOf(px);
          double luma = 10.0;  // outside the mirror
          if (rr < m.self_radius) {
            luma = 30.0;  // the robot's own reflection
          } else if (rr <= m.outer_radius) {
            luma = carpet.carpet_luma;
            if (const std::optional<camera::Vec2> floor = mirror.imageToRobot(px)) {
              const double d = floor->norm();
              for (double ring : carpet.distances) {
                if (std::abs(d - ring) <= carpet.ring_width / 2) luma = carpet.ring_luma;
              }
            }
          }
          sum += luma;
        }
      }
      frame[static_cast<std::size_t>(v) * w + u].y =
          static_cast<std::uint8_t>(std::clamp(std::lround(sum / (s * s)), 0L, 255L));
    }
  }
  camera::RealismFilter filter(realism, mirror);
  filter.apply(frame, frame_number);
  GreyImage out{w, h, {}};
  out.pixels.reserve(frame.size());
  for (const camera::Yuv& p : frame)
    out.pixels.push_back(p.y);
  return out;
}

std::vector<PosedImage> renderFieldFrames(const camera::MirrorModel& mirror,
                                          const field::FieldModel& field,
                                          const camera::RenderParams& render,
                                          const std::vector<geometry::Pose2>& poses,
                                          const camera::RealismParams& realism) {
  camera::RenderParams params = render;
  params.realism = realism;
  camera::SimRenderer renderer(mirror, field, params);
  std::vector<PosedImage> out;
  std::vector<std::uint8_t> yuyv;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    camera::SimScene scene;
    scene.robot = poses[i];
    scene.frame_number = i;
    renderer.render(scene, yuyv);
    out.push_back({greyFromFrame(renderer.view(yuyv)), poses[i]});
  }
  return out;
}

MirrorError compareMirrors(const camera::MirrorModel& truth, const camera::MirrorModel& fitted,
                           double up_to) {
  MirrorError e;
  const camera::MirrorParams& t = truth.params();
  const camera::MirrorParams& f = fitted.params();
  e.centre_px = (t.centre - f.centre).norm();
  e.offset_m = (t.axis_offset - f.axis_offset).norm();
  const double end = t.distance.imageRadius(up_to, 0.0);
  for (int deg = -179; deg <= 180; ++deg) {
    const double b = deg * std::numbers::pi / 180.0;
    // From 1 px outside the reflection (the fitted centre differs by a fraction of a pixel).
    for (double r = t.self_radius + 1.0; r <= end; r += 0.5) {
      const double dt = t.distance.floorDistance(r, b);
      const double df = f.distance.floorDistance(r, b);
      if (!std::isfinite(dt) || dt > up_to) continue;
      e.distance_percent =
          std::max(e.distance_percent, std::isfinite(df) ? 100.0 * std::abs(df - dt) / dt : 1e9);
      const camera::Vec2 px = t.centre + r * truth.imageDirection(b);
      if (truth.zone(px) == camera::MirrorZone::kOutside) continue;
      const std::optional<camera::Vec2> a = truth.imageToRobot(px);
      const std::optional<camera::Vec2> c = fitted.imageToRobot(px);
      e.floor_point_m = std::max(e.floor_point_m, a && c ? (*a - *c).norm() : 1e9);
    }
  }
  return e;
}

}  // namespace fieldline::calibration
