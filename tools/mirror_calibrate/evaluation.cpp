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
                           double up_to, double from) {
  MirrorError e;
  const camera::MirrorParams& t = truth.params();
  const camera::MirrorParams& f = fitted.params();
  e.centre_px = (t.centre - f.centre).norm();
  e.offset_m = (t.axis_offset - f.axis_offset).norm();
  // Pixel by pixel (every quarter pixel): what each model says the pixel shows. The distance
  // function is compared as the floor distance from each model's own axis, so a centre that the
  // fit moved to make up for a tilt is not counted twice.
  for (double v = 0.0; v <= t.height - 1; v += 0.25) {
    for (double u = 0.0; u <= t.width - 1; u += 0.25) {
      const camera::Vec2 px(u, v);
      if (truth.zone(px) != camera::MirrorZone::kUseful) continue;
      if (truth.radiusOf(px) < t.self_radius + 1.0 || fitted.radiusOf(px) < f.self_radius + 1.0) {
        continue;
      }
      const std::optional<camera::Vec2> ta = truth.imageToAxis(px);
      if (!ta || ta->norm() > up_to) continue;
      const std::optional<camera::Vec2> fa = fitted.imageToAxis(px);
      if (!fa) {
        e.distance_percent = std::max(e.distance_percent, ta->norm() >= from ? 1e9 : 0.0);
        e.floor_point_m = 1e9;
        continue;
      }
      if (ta->norm() >= from) {
        e.distance_percent =
            std::max(e.distance_percent, 100.0 * std::abs(fa->norm() - ta->norm()) / ta->norm());
      }
      e.floor_point_m =
          std::max(e.floor_point_m, (truth.axisToRobot(*ta) - fitted.axisToRobot(*fa)).norm());
    }
  }
  return e;
}

}  // namespace fieldline::calibration
