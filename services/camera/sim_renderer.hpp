// The simulated omni-directional camera: renders what a robot's camera sees from its true pose,
// through the inverse mirror model, as a raw YUYV 4:2:2 frame.
//
// Scene: green carpet with a brightness texture and uneven light (bright spots under lamps, side
// light through windows, seed 4.14), white lines at their true widths (field model), goals
// (coloured boxes for fu2004, white posts and crossbar for msl), the orange ball, other robots as
// black cylinders with a team marker band, the robot's own reflection in the mirror centre, black
// outside the mirror, the hall beyond the carpet, sensor noise and optional motion blur.
//
// Speed: everything that does not change with the pose is computed once: the floor point (robot
// frame) of every pixel, which mip level of the floor raster matches its footprint, and the
// floor raster itself (texture, lines and light baked in, in the field frame; with a raster
// cache, the cache file mapped read-only and shared, one copy for all cameras on the machine).
// Per frame each pixel costs one rotation and one raster lookup; objects are ray-cast only inside
// their image bounding boxes. render() allocates nothing after the first call.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/camera/floor_raster_cache.hpp"
#include "services/camera/realism.hpp"

namespace fieldline::camera {

struct LightSpot {
  // Field frame, m.
  Vec2 position = Vec2::Zero();
  // Standard deviation of the Gaussian bright spot, m.
  double radius = 1.0;
  // Brightness added at the centre (relative to 1).
  double gain = 0.3;
};

struct WindowLight {
  // Unit vector (field frame) toward the window side.
  Vec2 direction = Vec2::UnitY();
  // Brightness added at the carpet edge on that side.
  double gain = 0.0;
  // Distance over which it decays by e, m.
  double falloff = 2.0;
};

struct Lighting {
  double ambient = 1.0;
  std::vector<LightSpot> spots;
  WindowLight windows;

  // Brightness factor at a field point (carpet half extent for the window edge).
  double at(const Vec2& field_point, const Vec2& carpet_half_extent) const;
};

struct RenderParams {
  double max_floor_distance = 12.0;
  double floor_resolution = 0.01;
  Bgr carpet{45, 120, 40};
  Bgr line{225, 230, 230};
  Bgr outside_floor{95, 100, 100};
  Bgr hall{55, 60, 70};
  Bgr robot{28, 28, 28};
  Bgr robot_top{45, 45, 45};
  Bgr self{30, 30, 32};
  Bgr ball{10, 100, 240};
  Bgr goal_yellow{20, 200, 225};
  Bgr goal_blue{190, 90, 20};
  Bgr goal_white{225, 230, 230};
  Bgr own_marker{200, 60, 200};
  Bgr opponent_marker{210, 200, 40};
  double robot_height = 0.75;
  std::array<double, 2> marker_band{0.5, 0.65};
  double goal_post_thickness = 0.1;
  // Relative amplitude of coarse noise, fine noise and per-cell grain of the carpet brightness.
  std::array<double, 3> carpet_texture{0.06, 0.04, 0.03};
  Lighting lighting;
  // Noise standard deviation, 8-bit levels (the shipped configs' level,
  // config/camera/omni_sim.yaml).
  double noise_luma = 2.7;
  double noise_chroma = 1.7;
  std::uint32_t noise_seed = 1;
  // Poses sampled across the exposure; 1 = no motion blur.
  int motion_blur_samples = 1;
  // Post-process toward real frames (services/camera/realism.hpp); off by default.
  RealismParams realism;
};

// Reads the `render` section of a camera preset; throws config::Error with file:line.
RenderParams loadRenderParams(const config::Node& render);

// Another robot on the field: a cylinder standing on the floor.
struct SimRobot {
  // Field frame, m.
  Vec2 position = Vec2::Zero();
  // Footprint radius, m.
  double radius = 0.25;
  // True for a teammate (own marker colour), false for an opponent.
  bool teammate = false;
  // Clutter (evaluation tools): colours that replace the body's and the marker band's, e.g. a
  // robot with white parts or of another team's colour.
  std::optional<Bgr> body_colour;
  std::optional<Bgr> marker_colour;
};

// Clutter: an axis-aligned box in the field frame, e.g. a white object beyond the border, a
// person at the side, a flat white patch on the carpet (a few millimetres high).
struct SimBox {
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();
  Eigen::Vector3d hi = Eigen::Vector3d::Zero();
  Bgr colour{225, 230, 230};
};

struct SimBall {
  // Field frame, m (the ball lies on the floor).
  Vec2 position = Vec2::Zero();
  double radius = 0.11;
};

struct SimScene {
  // Field pose of the robot whose camera renders, at the middle of the exposure.
  geometry::Pose2 robot;
  // Its velocity in the field frame (m/s, rad/s), for motion blur.
  Vec2 velocity = Vec2::Zero();
  double omega = 0.0;
  // Exposure duration, s (motion blur spans it).
  double exposure = 0.008;
  std::vector<SimRobot> robots;
  std::optional<SimBall> ball;
  std::vector<SimBox> boxes;
  // Seeds the sensor noise together with RenderParams::noise_seed: the same number, the same
  // frame.
  std::uint64_t frame_number = 0;
};

class SimRenderer {
 public:
  // Precomputes the pixel table and the floor raster (a fraction of a second for an msl field).
  // With a `raster_cache_dir`, the raster is mapped from there when a valid file for exactly these
  // inputs exists, else built, written there and mapped (floor_raster_cache.hpp).
  // Throws std::invalid_argument for unusable parameters.
  SimRenderer(MirrorModel mirror, const field::FieldModel& field, RenderParams params,
              const std::string& raster_cache_dir = {});

  // Renders `scene` into `yuyv` (resized to height * stride on first use; stride = 2 * width).
  void render(const SimScene& scene, std::vector<std::uint8_t>& yuyv);

  int width() const { return mirror_.width(); }
  int height() const { return mirror_.height(); }
  int stride() const { return 2 * mirror_.width(); }
  FrameView view(const std::vector<std::uint8_t>& yuyv) const {
    return {yuyv.data(), width(), height(), stride(), PixelFormat::kYuyv};
  }
  const MirrorModel& mirror() const { return mirror_; }
  const RenderParams& params() const { return params_; }
  // The realism post-process (its knobs can change between frames, e.g. the light factor).
  RealismFilter& realism() { return realism_; }
  // The sensor noise by its portable loop on every pixel pair instead of its SSE2 loop (what
  // x86-64 builds run): the same bytes, which SimRenderer.ScalarNoiseGivesTheSameBytes checks.
  void setScalarNoise(bool scalar) { scalar_noise_ = scalar; }

  // Colour of the floor raster at a field point (finest level, lighting included, no noise).
  Yuv floorColour(const Vec2& field_point) const;

  // Where the floor raster came from, and why a cache file was not used or not written ("" when
  // nothing went wrong).
  RasterSource rasterSource() const { return raster_source_; }
  const std::string& rasterProblem() const { return raster_problem_; }
  // Whether the floor pass reads a read-only shared mapping of the cache file rasterPath() (one
  // copy for every camera on the machine) rather than a copy in this renderer's memory.
  bool rasterMapped() const { return raster_.mapped(); }
  const std::string& rasterPath() const { return raster_path_; }

 private:
  enum class PixelKind : std::uint8_t { kOutside, kSelf, kFloor, kHall };

  // A ray-cast object, in the field frame.
  using Box = SimBox;

  void buildPixelTable();
  // The raster's levels, row-major, finest first (sim_floor.cpp).
  std::vector<FloorRasterLevel> buildFloorRaster(const field::FieldModel& field) const;
  // In floor_raster_cache.cpp: the cached raster mapped, or buildFloorRaster (and write the cache
  // and map it).
  void loadOrBuildFloorRaster(const field::FieldModel& field, const std::string& cache_dir);
  void buildGoals(const field::FieldModel& field);
  // Renders the scene seen by a robot at `robot_pose`; the helpers below take the mirror axis'
  // pose (the robot pose moved by the mirror's axis_offset).
  void renderOnce(const geometry::Pose2& robot_pose, const SimScene& scene);
  void renderFloor(const geometry::Pose2& pose);
  void renderRobot(const geometry::Pose2& pose, const SimRobot& robot);
  void renderBall(const geometry::Pose2& pose, const SimBall& ball);
  void renderBox(const geometry::Pose2& pose, const Box& box);
  // Image bounding box [u0, u1) x [v0, v1) of an object whose footprint, seen from the robot,
  // spans bearings centre_bearing +- half_span from distance near to far (robot frame) and that
  // rises to `top` metres.
  bool objectBounds(double centre_bearing, double half_span, double near, double far, double top,
                    std::array<int, 4>& bounds) const;
  Yuv lit(Bgr colour, const Vec2& field_point) const;
  void finish(const SimScene& scene, std::vector<std::uint8_t>& yuyv);

  MirrorModel mirror_;
  RenderParams params_;
  Vec2 carpet_half_;
  Vec2 raster_origin_;

  // Per pixel (row-major): kind, floor point in the mirror's axis frame (the objects' rays).
  std::vector<PixelKind> kind_;
  std::vector<float> floor_x_;
  std::vector<float> floor_y_;
  // The kFloor pixels grouped by mip level, row-major within a level: floor point (axis frame)
  // and pixel index; level_end_[l] is where level l's run ends.
  std::vector<float> floor_run_x_;
  std::vector<float> floor_run_y_;
  std::vector<std::int32_t> floor_run_index_;
  std::vector<std::size_t> level_end_;
  std::vector<Yuv> static_layer_;  // outside, self, hall
  // The runs of pixels that are not kFloor (first pixel, count), row-major: all of the static
  // layer a frame needs (the floor pass writes every kFloor pixel).
  std::vector<std::array<std::int32_t, 2>> static_runs_;

  // The floor raster in tiles, what the floor pass reads: mapped from the cache file, or in
  // memory without one. The row-major cells are not kept.
  FloorRaster raster_;
  RasterSource raster_source_ = RasterSource::kBuilt;
  std::string raster_problem_;
  std::string raster_path_;
  Yuv outside_floor_yuv_;
  std::vector<Box> goal_boxes_;

  std::vector<Yuv> frame_;                                 // current sub-frame, one Yuv per pixel
  std::vector<std::array<std::uint16_t, 3>> accumulator_;  // motion blur sums
  // The sensor noise (finish): a table of N(0, 1) draws in whole luma and chroma levels, its
  // standard deviation the asked one (noise_luma, noise_chroma).
  std::vector<std::int16_t> luma_noise_;
  std::vector<std::int16_t> chroma_noise_;
  RealismFilter realism_;
  bool scalar_noise_ = false;
};

}  // namespace fieldline::camera
