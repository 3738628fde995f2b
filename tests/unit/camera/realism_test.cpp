// The realism post-process (services/camera/realism.hpp): each knob does what it says on a
// synthetic frame, the identity changes nothing, the noise is reproducible, bad values and
// unknown keys are refused; in the renderer it changes the rendered frame as configured.
#include "services/camera/realism.hpp"

#include <cmath>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "common/field/field_model.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/sim_renderer.hpp"

namespace fieldline::camera {
namespace realism_test {

MirrorModel smallMirror() {
  MirrorParams p;
  p.width = 64;
  p.height = 48;
  p.centre = {31.5, 23.5};
  p.outer_radius = 30.0;
  p.useful_radius = 27.0;
  p.self_radius = 3.0;
  return MirrorModel(p);
}

std::vector<Yuv> flat(const MirrorModel& m, Yuv c) {
  return std::vector<Yuv>(static_cast<std::size_t>(m.width()) * m.height(), c);
}

const Yuv& at(const std::vector<Yuv>& f, const MirrorModel& m, int u, int v) {
  return f[static_cast<std::size_t>(v) * m.width() + u];
}

TEST(Realism, IdentityChangesNothing) {
  const MirrorModel m = smallMirror();
  RealismFilter filter(RealismParams{}, m);
  EXPECT_FALSE(filter.enabled());
  std::vector<Yuv> f = flat(m, {100, 90, 80});
  f[7] = {200, 130, 140};
  const std::vector<Yuv> before = f;
  filter.apply(f, 3);
  for (std::size_t i = 0; i < f.size(); ++i) {
    EXPECT_EQ(f[i].y, before[i].y);
    EXPECT_EQ(f[i].u, before[i].u);
    EXPECT_EQ(f[i].v, before[i].v);
  }
}

TEST(Realism, LightFactorScalesLumaAndChromaLikeAGainOnRgb) {
  const MirrorModel m = smallMirror();
  RealismParams p;
  p.light_factor = 0.5;
  RealismFilter filter(p, m);
  std::vector<Yuv> f = flat(m, {100, 88, 168});
  filter.apply(f, 0);
  EXPECT_EQ(at(f, m, 10, 10).y, 50);
  EXPECT_EQ(at(f, m, 10, 10).u, 108);  // 128 - 40 / 2
  EXPECT_EQ(at(f, m, 10, 10).v, 148);  // 128 + 40 / 2
}

TEST(Realism, GradientAndVignettingShapeTheBrightness) {
  const MirrorModel m = smallMirror();
  RealismParams p;
  p.light_gradient = 0.4;
  p.light_gradient_angle = 0.0;  // brighter toward +u
  RealismFilter gradient(p, m);
  std::vector<Yuv> f = flat(m, {100, 128, 128});
  gradient.apply(f, 0);
  // 30 px right of the centre: factor 1 + 0.4 * 30 / 30.
  EXPECT_NEAR(at(f, m, 61, 23).y, 100 * (1.0 + 0.4 * 29.5 / 30.0), 1.0);
  EXPECT_NEAR(at(f, m, 2, 23).y, 100 * (1.0 - 0.4 * 29.5 / 30.0), 1.0);
  EXPECT_NEAR(at(f, m, 31, 10).y, 100, 1.0);

  RealismParams pv;
  pv.vignetting = 0.5;
  RealismFilter vignette(pv, m);
  std::vector<Yuv> g = flat(m, {200, 128, 128});
  vignette.apply(g, 0);
  EXPECT_NEAR(at(g, m, 31, 23).y, 200, 1.0);
  // 20 px out: 1 - 0.5 * (20.006 / 30)^2.
  EXPECT_NEAR(at(g, m, 51, 23).y, 200 * (1.0 - 0.5 * std::pow(19.5 / 30.0, 2)), 1.5);
  EXPECT_LT(at(g, m, 0, 0).y, at(g, m, 16, 12).y);
}

TEST(Realism, SaturationAndShiftMoveTheChroma) {
  const MirrorModel m = smallMirror();
  RealismParams p;
  p.saturation = 0.0;
  RealismFilter grey(p, m);
  std::vector<Yuv> f = flat(m, {120, 60, 200});
  grey.apply(f, 0);
  EXPECT_EQ(at(f, m, 5, 5).u, 128);
  EXPECT_EQ(at(f, m, 5, 5).v, 128);
  EXPECT_EQ(at(f, m, 5, 5).y, 120);

  p.saturation = 0.5;
  p.chroma_shift = {10.0, -6.0};
  RealismFilter washed(p, m);
  std::vector<Yuv> g = flat(m, {120, 60, 200});
  washed.apply(g, 0);
  EXPECT_EQ(at(g, m, 5, 5).u, 128 - 34 + 10);
  EXPECT_EQ(at(g, m, 5, 5).v, 128 + 36 - 6);
}

TEST(Realism, BlurSpreadsAnEdgeAndKeepsFlatAreas) {
  const MirrorModel m = smallMirror();
  RealismParams p;
  p.blur_sigma = 1.5;
  RealismFilter blur(p, m);
  std::vector<Yuv> f = flat(m, {50, 128, 128});
  for (int v = 0; v < m.height(); ++v) {
    for (int u = 32; u < m.width(); ++u)
      f[static_cast<std::size_t>(v) * m.width() + u].y = 200;
  }
  blur.apply(f, 0);
  EXPECT_EQ(at(f, m, 5, 20).y, 50);
  EXPECT_EQ(at(f, m, 60, 20).y, 200);
  // Next to the edge the values lie between, monotonically rising.
  EXPECT_GT(at(f, m, 31, 20).y, 60);
  EXPECT_LT(at(f, m, 32, 20).y, 190);
  for (int u = 28; u < 36; ++u)
    EXPECT_LE(at(f, m, u, 20).y, at(f, m, u + 1, 20).y);
}

TEST(Realism, ShotNoiseGrowsWithTheSignalAndIsReproducible) {
  const MirrorModel m = smallMirror();
  RealismParams p;
  p.shot_noise = 16.0;
  p.seed = 7;
  RealismFilter noise(p, m);
  auto stddev = [&](std::uint8_t y, std::uint64_t frame) {
    std::vector<Yuv> f = flat(m, {y, 128, 128});
    noise.apply(f, frame);
    double sum = 0, sq = 0;
    for (const Yuv& c : f) {
      sum += c.y;
      sq += double(c.y) * c.y;
    }
    const double mean = sum / f.size();
    return std::sqrt(sq / f.size() - mean * mean);
  };
  const double bright = stddev(180, 1);
  const double dark = stddev(60, 1);
  EXPECT_NEAR(bright, 16.0 * std::sqrt(180.0 / 255.0), 1.0);
  EXPECT_NEAR(dark, 16.0 * std::sqrt(60.0 / 255.0), 1.0);

  std::vector<Yuv> a = flat(m, {120, 128, 128});
  std::vector<Yuv> b = a;
  std::vector<Yuv> c = a;
  noise.apply(a, 5);
  noise.apply(b, 5);
  noise.apply(c, 6);
  int same = 0, differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    same += a[i].y == b[i].y && a[i].u == b[i].u && a[i].v == b[i].v;
    differ += a[i].y != c[i].y;
  }
  EXPECT_EQ(same, static_cast<int>(a.size()));
  EXPECT_GT(differ, static_cast<int>(a.size()) / 2);
}

TEST(Realism, BadValuesAndUnknownKeysAreRefused) {
  const MirrorModel m = smallMirror();
  RealismParams p;
  p.light_factor = 0.0;
  EXPECT_THROW(RealismFilter(p, m), std::invalid_argument);
  p = {};
  p.vignetting = 1.0;
  EXPECT_THROW(RealismFilter(p, m), std::invalid_argument);
  p = {};
  p.blur_sigma = -1.0;
  EXPECT_THROW(RealismFilter(p, m), std::invalid_argument);

  const RealismParams loaded = loadRealismParams(config::Node::loadString(
      "light_factor: 0.7\nsaturation: 0.6\nchroma_shift: [4, -3]\nblur_sigma: 0.8\n"));
  EXPECT_DOUBLE_EQ(loaded.light_factor, 0.7);
  EXPECT_DOUBLE_EQ(loaded.saturation, 0.6);
  EXPECT_DOUBLE_EQ(loaded.chroma_shift[1], -3.0);
  EXPECT_DOUBLE_EQ(loaded.vignetting, 0.0);
  EXPECT_THROW(loadRealismParams(config::Node::loadString("light_factr: 0.7\n")), config::Error);
  EXPECT_THROW(loadRealismParams(config::Node::loadString("saturation: 5\n")), config::Error);
}

TEST(Realism, TheRendererAppliesItsRealismSectionAndFollowsTheLightFactor) {
  CameraConfig config = loadCameraConfigPreset("omni_sim");
  config.render->noise_luma = 0.0;
  config.render->noise_chroma = 0.0;
  const field::FieldModel field = field::loadFieldPreset("msl");
  SimRenderer renderer(config.model.mirror, field, *config.render);
  SimScene scene;
  scene.robot = {1.0, 0.5, 0.3};
  std::vector<std::uint8_t> plain, dim;
  renderer.render(scene, plain);
  RealismParams p;
  p.light_factor = 0.5;
  renderer.realism().setParams(p);
  renderer.render(scene, dim);
  ASSERT_EQ(plain.size(), dim.size());
  double lumaPlain = 0, lumaDim = 0;
  for (std::size_t i = 0; i < plain.size(); i += 2) {
    lumaPlain += plain[i];
    lumaDim += dim[i];
  }
  EXPECT_NEAR(lumaDim / lumaPlain, 0.5, 0.01);

  // Read from the preset's render section.
  const config::Node root = config::Node::loadString(
      "max_floor_distance: 8.0\nfloor_resolution: 0.01\ncarpet_bgr: [45, 120, 40]\n"
      "line_bgr: [225, 230, 230]\noutside_floor_bgr: [95, 100, 100]\nhall_bgr: [55, 60, 70]\n"
      "robot_bgr: [28, 28, 28]\nrobot_top_bgr: [45, 45, 45]\nself_bgr: [30, 30, 32]\n"
      "ball_bgr: [10, 100, 240]\ngoal_yellow_bgr: [20, 200, 225]\ngoal_blue_bgr: [190, 90, 20]\n"
      "goal_white_bgr: [225, 230, 230]\nown_marker_bgr: [200, 60, 200]\n"
      "opponent_marker_bgr: [210, 200, 40]\nrobot_height: 0.75\nmarker_band: [0.3, 0.45]\n"
      "goal_post_thickness: 0.1\ncarpet_texture: [0.06, 0.04, 0.03]\n"
      "lighting: {ambient: 0.85}\nnoise: {luma: 3.0, chroma: 2.0, seed: 1}\n"
      "motion_blur_samples: 1\nrealism: {saturation: 0.5, blur_sigma: 1.0}\n");
  const RenderParams loaded = loadRenderParams(root);
  EXPECT_DOUBLE_EQ(loaded.realism.saturation, 0.5);
  EXPECT_DOUBLE_EQ(loaded.realism.blur_sigma, 1.0);
}

}  // namespace realism_test
}  // namespace fieldline::camera
