// The `render` section of a camera preset (loadRenderParams, sim_renderer.hpp).
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "services/camera/sim_renderer.hpp"

namespace fieldline::camera {
namespace {

Bgr loadBgr(const config::Node& n, const std::string& key) {
  const std::vector<int> c = n.getList<int>(key, 3);
  for (const int x : c) {
    if (x < 0 || x > 255) n.fail(key, "colour components must be in 0..255");
  }
  return {static_cast<std::uint8_t>(c[0]), static_cast<std::uint8_t>(c[1]),
          static_cast<std::uint8_t>(c[2])};
}

Vec2 loadVec2(const config::Node& n, const std::string& key, double limit) {
  const std::vector<double> v = n.getList<double>(key, 2);
  if (std::abs(v[0]) > limit || std::abs(v[1]) > limit) {
    n.fail(key, "components must be within +-" + std::to_string(limit));
  }
  return {v[0], v[1]};
}

}  // namespace

RenderParams loadRenderParams(const config::Node& n) {
  RenderParams p;
  p.max_floor_distance = n.get<double>("max_floor_distance", 0.5, 100.0);
  p.floor_resolution = n.get<double>("floor_resolution", 0.002, 0.2);
  p.carpet = loadBgr(n, "carpet_bgr");
  p.line = loadBgr(n, "line_bgr");
  p.outside_floor = loadBgr(n, "outside_floor_bgr");
  p.hall = loadBgr(n, "hall_bgr");
  p.robot = loadBgr(n, "robot_bgr");
  p.robot_top = loadBgr(n, "robot_top_bgr");
  p.self = loadBgr(n, "self_bgr");
  p.ball = loadBgr(n, "ball_bgr");
  p.goal_yellow = loadBgr(n, "goal_yellow_bgr");
  p.goal_blue = loadBgr(n, "goal_blue_bgr");
  p.goal_white = loadBgr(n, "goal_white_bgr");
  p.own_marker = loadBgr(n, "own_marker_bgr");
  p.opponent_marker = loadBgr(n, "opponent_marker_bgr");
  p.robot_height = n.get<double>("robot_height", 0.1, 2.0);
  const std::vector<double> band = n.getList<double>("marker_band", 2);
  if (!(band[0] >= 0.0 && band[0] < band[1] && band[1] <= p.robot_height)) {
    n.fail("marker_band", "expected [bottom, top] with 0 <= bottom < top <= robot_height");
  }
  p.marker_band = {band[0], band[1]};
  p.goal_post_thickness = n.get<double>("goal_post_thickness", 0.01, 0.5);
  const std::vector<double> tex = n.getList<double>("carpet_texture", 3);
  for (const double t : tex) {
    if (!(t >= 0.0 && t <= 0.5)) n.fail("carpet_texture", "amplitudes must be in [0, 0.5]");
  }
  p.carpet_texture = {tex[0], tex[1], tex[2]};

  const config::Node light = n.child("lighting");
  p.lighting.ambient = light.get<double>("ambient", 0.05, 3.0);
  if (light.has("spots")) {
    for (const config::Node& s : light.children("spots")) {
      LightSpot spot;
      spot.position = loadVec2(s, "position", 100.0);
      spot.radius = s.get<double>("radius", 0.05, 50.0);
      spot.gain = s.get<double>("gain", 0.0, 3.0);
      s.rejectUnknownKeys();
      p.lighting.spots.push_back(spot);
    }
  } else {
    (void)light.childIf("spots");
  }
  if (const std::optional<config::Node> win = light.childIf("windows")) {
    const Vec2 dir = loadVec2(*win, "direction", 1.0);
    if (dir.norm() < 0.5) win->fail("direction", "expected a unit vector");
    p.lighting.windows.direction = dir.normalized();
    p.lighting.windows.gain = win->get<double>("gain", 0.0, 3.0);
    p.lighting.windows.falloff = win->get<double>("falloff", 0.05, 50.0);
    win->rejectUnknownKeys();
  }
  light.rejectUnknownKeys();

  const config::Node noise = n.child("noise");
  p.noise_luma = noise.get<double>("luma", 0.0, 50.0);
  p.noise_chroma = noise.get<double>("chroma", 0.0, 50.0);
  p.noise_seed = static_cast<std::uint32_t>(noise.get<int>("seed", 0, 1 << 30));
  noise.rejectUnknownKeys();
  p.motion_blur_samples = n.get<int>("motion_blur_samples", 1, 16);
  if (const std::optional<config::Node> realism = n.childIf("realism")) {
    p.realism = loadRealismParams(*realism);
  }
  n.rejectUnknownKeys();
  return p;
}

}  // namespace fieldline::camera
