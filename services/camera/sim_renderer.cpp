#include "services/camera/sim_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

namespace fieldline::camera {
namespace {

constexpr int kNoiseTableBits = 12;
constexpr float kNoiseTableScale = 16.0f;  // noise_table_ holds N(0,1) * 16

// Deterministic hash of integer lattice coordinates to [-1, 1] (texture noise).
float latticeNoise(std::int64_t i, std::int64_t j, std::uint32_t seed) {
  std::uint64_t h = static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull ^
                    static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4Full ^ seed;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return static_cast<float>(h >> 40) / static_cast<float>(1ull << 23) - 1.0f;
}

// Smooth value noise in [-1, 1] with features about `scale` metres apart.
float valueNoise(const Vec2& p, double scale, std::uint32_t seed) {
  const double gx = p.x() / scale;
  const double gy = p.y() / scale;
  const double fx = std::floor(gx);
  const double fy = std::floor(gy);
  const auto i = static_cast<std::int64_t>(fx);
  const auto j = static_cast<std::int64_t>(fy);
  auto smooth = [](double t) { return t * t * (3.0 - 2.0 * t); };
  const double tx = smooth(gx - fx);
  const double ty = smooth(gy - fy);
  const double a = latticeNoise(i, j, seed) * (1 - tx) + latticeNoise(i + 1, j, seed) * tx;
  const double b = latticeNoise(i, j + 1, seed) * (1 - tx) + latticeNoise(i + 1, j + 1, seed) * tx;
  return static_cast<float>(a * (1 - ty) + b * ty);
}

Bgr scaleBgr(Bgr c, double k) {
  auto s = [k](std::uint8_t x) {
    return static_cast<std::uint8_t>(std::clamp(x * k + 0.5, 0.0, 255.0));
  };
  return {s(c.b), s(c.g), s(c.r)};
}

Bgr mixBgr(Bgr a, Bgr b, double t) {
  auto m = [t](std::uint8_t x, std::uint8_t y) {
    return static_cast<std::uint8_t>(std::clamp(x + (y - x) * t + 0.5, 0.0, 255.0));
  };
  return {m(a.b, b.b), m(a.g, b.g), m(a.r, b.r)};
}

std::uint8_t clampByte(int x) {
  return static_cast<std::uint8_t>(std::clamp(x, 0, 255));
}

std::uint32_t mixSeed(std::uint32_t seed, std::uint64_t frame) {
  std::uint64_t h = (frame + 1) * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(seed) << 17);
  h ^= h >> 33;
  h *= 0xFF51AFD7ED558CCDull;
  h ^= h >> 33;
  const auto out = static_cast<std::uint32_t>(h);
  return out == 0 ? 0x6D2B79F5u : out;
}

}  // namespace

double Lighting::at(const Vec2& p, const Vec2& carpet_half_extent) const {
  double light = ambient;
  for (const LightSpot& spot : spots) {
    light += spot.gain *
             std::exp(-(p - spot.position).squaredNorm() / (2.0 * spot.radius * spot.radius));
  }
  if (windows.gain > 0.0) {
    // Distance from the carpet edge on the window side, along the window direction.
    const Vec2 n = windows.direction;
    const double edge =
        std::abs(n.x()) * carpet_half_extent.x() + std::abs(n.y()) * carpet_half_extent.y();
    const double inside = std::max(0.0, edge - p.dot(n));
    light += windows.gain * std::exp(-inside / windows.falloff);
  }
  return light;
}

// --- construction ---

SimRenderer::SimRenderer(MirrorModel mirror, const field::FieldModel& field, RenderParams params,
                         const std::string& raster_cache_dir)
    : mirror_(std::move(mirror)), params_(std::move(params)), realism_(params_.realism, mirror_) {
  if (!(params_.floor_resolution >= 0.002 && params_.floor_resolution <= 0.2)) {
    throw std::invalid_argument("renderer: floor_resolution must be in [0.002, 0.2] m");
  }
  if (!(params_.max_floor_distance > 0.0) || params_.motion_blur_samples < 1 ||
      params_.motion_blur_samples > 16) {
    throw std::invalid_argument(
        "renderer: max_floor_distance must be > 0 and motion_blur_samples in [1, 16]");
  }
  if (mirror_.width() % 2 != 0) throw std::invalid_argument("renderer: YUYV needs an even width");
  carpet_half_ = field.carpetHalfExtent();
  raster_origin_ = -carpet_half_;
  loadOrBuildFloorRaster(field, raster_cache_dir);
  outside_floor_yuv_ = yuvFromBgr(scaleBgr(params_.outside_floor, params_.lighting.ambient));
  buildGoals(field);
  buildPixelTable();

  std::mt19937 rng(params_.noise_seed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  noise_table_.resize(std::size_t{1} << kNoiseTableBits);
  for (auto& n : noise_table_) {
    n = static_cast<std::int8_t>(
        std::clamp(std::lround(gauss(rng) * kNoiseTableScale), -127l, 127l));
  }
}

Yuv SimRenderer::lit(Bgr colour, const Vec2& field_point) const {
  return yuvFromBgr(scaleBgr(colour, params_.lighting.at(field_point, carpet_half_)));
}

// What this computes from its inputs is cached on disk (floor_raster_cache.hpp): a change here
// that gives another raster for the same inputs must bump kFloorRasterVersion.
void SimRenderer::buildFloorRaster(const field::FieldModel& field) {
  RasterLevel base;
  base.cell = params_.floor_resolution;
  base.inv_cell = 1.0 / base.cell;
  base.cols = static_cast<int>(std::ceil(2.0 * carpet_half_.x() / base.cell));
  base.rows = static_cast<int>(std::ceil(2.0 * carpet_half_.y() / base.cell));
  base.cells.resize(static_cast<std::size_t>(base.cols) * base.rows);

  const auto& tex = params_.carpet_texture;
  const std::vector<Vec2>& marks = field.penaltyMarks();
  const double mark_radius = field.dimensions().penalty_mark_diameter / 2.0;
  // Most of the carpet is far from every line, and the closest-line search is most of the
  // start-up time (a restarted camera should be back within a second). The distance to the lines
  // changes by at most the distance moved, so one search at the centre of a block of cells
  // proves the whole block uncovered when it is farther than the widest line's half width plus
  // half a cell plus the block's half diagonal. The raster is unchanged, only built faster.
  double max_half_width = 0.0;
  for (const auto& s : field.segments())
    max_half_width = std::max(max_half_width, 0.5 * s.width);
  for (const auto& a : field.arcs())
    max_half_width = std::max(max_half_width, 0.5 * a.width);
  constexpr int kBlock = 16;
  const double block_half_diagonal = std::sqrt(2.0) * 0.5 * (kBlock - 1) * base.cell;
  const double uncovered_beyond = max_half_width + 0.5 * base.cell + block_half_diagonal + 1e-6;
  const int block_cols = (base.cols + kBlock - 1) / kBlock;
  std::vector<bool> block_uncovered(static_cast<std::size_t>(block_cols) *
                                    ((base.rows + kBlock - 1) / kBlock));
  for (std::size_t b = 0; b < block_uncovered.size(); ++b) {
    const double bi = static_cast<double>(b % block_cols) * kBlock + 0.5 * kBlock;
    const double bj = static_cast<double>(b / block_cols) * kBlock + 0.5 * kBlock;
    const Vec2 centre = raster_origin_ + Vec2(bi * base.cell, bj * base.cell);
    block_uncovered[b] = field.distance(centre) > uncovered_beyond;
  }
  for (int j = 0; j < base.rows; ++j) {
    for (int i = 0; i < base.cols; ++i) {
      const Vec2 p = raster_origin_ + Vec2((i + 0.5) * base.cell, (j + 0.5) * base.cell);
      // Line coverage of this cell, antialiased over one cell.
      double coverage = 0.0;
      if (!block_uncovered[static_cast<std::size_t>(j / kBlock) * block_cols + i / kBlock]) {
        const field::FieldModel::Closest c = field.closestPoint(p);
        const double half_width =
            0.5 * (c.is_arc ? field.arcs()[c.element].width : field.segments()[c.element].width);
        coverage = std::clamp((half_width - c.distance) / base.cell + 0.5, 0.0, 1.0);
      }
      for (const Vec2& m : marks) {
        const double d = (p - m).norm();
        coverage = std::max(coverage, std::clamp((mark_radius - d) / base.cell + 0.5, 0.0, 1.0));
      }
      const double grain = latticeNoise(i, j, params_.noise_seed * 7 + 3);
      const double texture = 1.0 + tex[0] * valueNoise(p, 0.6, params_.noise_seed) +
                             tex[1] * valueNoise(p, 0.08, params_.noise_seed + 1) + tex[2] * grain;
      const Bgr carpet = scaleBgr(params_.carpet, texture);
      const Bgr line = scaleBgr(params_.line, 1.0 + 0.3 * tex[2] * grain);
      const Bgr floor = mixBgr(carpet, line, coverage);
      base.cells[static_cast<std::size_t>(j) * base.cols + i] =
          yuvFromBgr(scaleBgr(floor, params_.lighting.at(p, carpet_half_)));
    }
  }
  raster_.push_back(std::move(base));

  // Mip levels: 2x2 averages, until cells reach about half a metre.
  while (raster_.back().cell < 0.5 && raster_.back().cols > 4 && raster_.back().rows > 4) {
    const RasterLevel& fine = raster_.back();
    RasterLevel coarse;
    coarse.cell = fine.cell * 2.0;
    coarse.inv_cell = 1.0 / coarse.cell;
    coarse.cols = (fine.cols + 1) / 2;
    coarse.rows = (fine.rows + 1) / 2;
    coarse.cells.resize(static_cast<std::size_t>(coarse.cols) * coarse.rows);
    for (int j = 0; j < coarse.rows; ++j) {
      for (int i = 0; i < coarse.cols; ++i) {
        int sy = 0, su = 0, sv = 0;
        for (int dj = 0; dj < 2; ++dj) {
          for (int di = 0; di < 2; ++di) {
            const int fi = std::min(2 * i + di, fine.cols - 1);
            const int fj = std::min(2 * j + dj, fine.rows - 1);
            const Yuv& c = fine.cells[static_cast<std::size_t>(fj) * fine.cols + fi];
            sy += c.y;
            su += c.u;
            sv += c.v;
          }
        }
        coarse.cells[static_cast<std::size_t>(j) * coarse.cols + i] = {
            static_cast<std::uint8_t>((sy + 2) / 4), static_cast<std::uint8_t>((su + 2) / 4),
            static_cast<std::uint8_t>((sv + 2) / 4)};
      }
    }
    raster_.push_back(std::move(coarse));
  }
}

void SimRenderer::buildGoals(const field::FieldModel& field) {
  const double t = params_.goal_post_thickness;
  for (const field::Goal& g : field.goals()) {
    const Bgr colour = g.colour == field::GoalColour::kYellow ? params_.goal_yellow
                       : g.colour == field::GoalColour::kBlue ? params_.goal_blue
                                                              : params_.goal_white;
    const double sx = g.outward.x() >= 0.0 ? 1.0 : -1.0;  // goals lie along the x axis
    const double mouth = g.mouth_centre.x();
    const double back = mouth + sx * g.depth;
    const double half = g.width / 2.0;
    const double cy = g.mouth_centre.y();
    auto box = [&](double x0, double x1, double y0, double y1, double z0, double z1) {
      goal_boxes_.push_back({Eigen::Vector3d(std::min(x0, x1), std::min(y0, y1), z0),
                             Eigen::Vector3d(std::max(x0, x1), std::max(y0, y1), z1), colour});
    };
    // Posts just outside the mouth's width, on the goal line's outer edge, and the crossbar.
    box(mouth, mouth + sx * t, cy + half, cy + half + t, 0.0, g.height + t);
    box(mouth, mouth + sx * t, cy - half - t, cy - half, 0.0, g.height + t);
    box(mouth, mouth + sx * t, cy - half - t, cy + half + t, g.height, g.height + t);
    if (g.colour != field::GoalColour::kWhite) {
      // The coloured goals of 2004 are boxes painted inside: back wall and side walls.
      box(back, back + sx * t, cy - half - t, cy + half + t, 0.0, g.height + t);
      box(mouth, back, cy + half, cy + half + t, 0.0, g.height + t);
      box(mouth, back, cy - half - t, cy - half, 0.0, g.height + t);
    } else {
      // The white msl goal: a frame at the back holding the net (the net itself is see-through).
      box(back, back + sx * t, cy + half, cy + half + t, 0.0, g.height + t);
      box(back, back + sx * t, cy - half - t, cy - half, 0.0, g.height + t);
    }
  }
}

void SimRenderer::buildPixelTable() {
  const int w = mirror_.width();
  const int h = mirror_.height();
  const std::size_t n = static_cast<std::size_t>(w) * h;
  kind_.assign(n, PixelKind::kOutside);
  floor_x_.assign(n, 0.0f);
  floor_y_.assign(n, 0.0f);
  level_.assign(n, 0);
  static_layer_.assign(n, Yuv{6, 128, 128});
  floor_pixels_.clear();

  const Yuv hall = yuvFromBgr(scaleBgr(params_.hall, params_.lighting.ambient));
  const double self_radius = mirror_.params().self_radius;
  const int max_level = static_cast<int>(raster_.size()) - 1;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      const Vec2 px(u, v);
      const MirrorZone zone = mirror_.zone(px);
      if (zone == MirrorZone::kOutside) continue;
      if (zone == MirrorZone::kSelf) {
        // The robot's own reflection: its dark top plate with a brighter rim of the camera mount.
        const double r = mirror_.radiusOf(px) / self_radius;
        const bool rim = r > 0.55 && r < 0.7;
        kind_[i] = PixelKind::kSelf;
        static_layer_[i] = yuvFromBgr(rim ? scaleBgr(params_.self, 2.5) : params_.self);
        continue;
      }
      // Floor points in the axis frame: the scene is drawn from the mirror axis' pose.
      const std::optional<Vec2> floor = mirror_.imageToAxis(px);
      if (!floor) continue;
      floor_x_[i] = static_cast<float>(floor->x());
      floor_y_[i] = static_cast<float>(floor->y());
      if (floor->norm() > params_.max_floor_distance) {
        kind_[i] = PixelKind::kHall;
        static_layer_[i] = hall;
        continue;
      }
      kind_[i] = PixelKind::kFloor;
      // The level whose cells are about half the pixel's footprint (0.35 to 0.71 of it):
      // interpolated between their centres (renderFloor), they blur the floor over about one
      // pixel. Cells as large as the footprint (as until bias10i) blurred a line 4.5 m away over
      // 16 cm of floor and shifted its centre outward by a centimetre or two.
      const Vec2 mpp = mirror_.metresPerPixel(px);
      const double footprint = std::max(mpp.x(), mpp.y());
      const int level =
          static_cast<int>(std::lround(std::log2(footprint / params_.floor_resolution))) - 1;
      level_[i] = static_cast<std::uint8_t>(std::clamp(level, 0, max_level));
      floor_pixels_.push_back(static_cast<std::int32_t>(i));
    }
  }
}

// --- per frame ---

Yuv SimRenderer::floorColour(const Vec2& p) const {
  const RasterLevel& l = raster_.front();
  const double gx = (p.x() - raster_origin_.x()) * l.inv_cell;
  const double gy = (p.y() - raster_origin_.y()) * l.inv_cell;
  if (!(gx >= 0.0 && gy >= 0.0 && gx < l.cols && gy < l.rows)) return outside_floor_yuv_;
  return l.cells[static_cast<std::size_t>(gy) * l.cols + static_cast<std::size_t>(gx)];
}

void SimRenderer::renderFloor(const geometry::Pose2& pose) {
  const float c = static_cast<float>(std::cos(pose.phi));
  const float s = static_cast<float>(std::sin(pose.phi));
  const float ox = static_cast<float>(pose.x - raster_origin_.x());
  const float oy = static_cast<float>(pose.y - raster_origin_.y());
  // Each cell holds its area's mean colour at its centre; a pixel's colour is interpolated
  // bilinearly between the four cell centres around its floor point. Taking the colour of the
  // cell the point falls in (as until bias10i) moved a line's edges to the cells' boundaries,
  // which are fixed on the field: every frame saw a line up to half a coarse cell (4-8 cm at
  // 3-6 m) off, the same way, and fusion's line matching inherited a bias of 1-2 cm wherever the
  // visible lines lie on one side of the robot (docs/fusion.md, tenth round).
  for (const std::int32_t i : floor_pixels_) {
    const float x = floor_x_[i];
    const float y = floor_y_[i];
    const RasterLevel& l = raster_[level_[i]];
    const float inv = static_cast<float>(l.inv_cell);
    const float gx = (ox + c * x - s * y) * inv;
    const float gy = (oy + s * x + c * y) * inv;
    if (!(gx >= 0.0f && gy >= 0.0f && gx < static_cast<float>(l.cols) &&
          gy < static_cast<float>(l.rows))) {
      frame_[i] = outside_floor_yuv_;
      continue;
    }
    // Cell-centre coordinates; at the raster's edge the edge cells are repeated.
    const float cx = gx - 0.5f, cy = gy - 0.5f;
    const int i0 = cx < 0.0f ? -1 : static_cast<int>(cx);
    const int j0 = cy < 0.0f ? -1 : static_cast<int>(cy);
    const int fx = static_cast<int>((cx - static_cast<float>(i0)) * 256.0f);
    const int fy = static_cast<int>((cy - static_cast<float>(j0)) * 256.0f);
    const std::size_t a = static_cast<std::size_t>(std::max(i0, 0));
    const std::size_t b = static_cast<std::size_t>(std::min(i0 + 1, l.cols - 1));
    const std::size_t row0 = static_cast<std::size_t>(std::max(j0, 0)) * l.cols;
    const std::size_t row1 = static_cast<std::size_t>(std::min(j0 + 1, l.rows - 1)) * l.cols;
    const Yuv& p00 = l.cells[row0 + a];
    const Yuv& p10 = l.cells[row0 + b];
    const Yuv& p01 = l.cells[row1 + a];
    const Yuv& p11 = l.cells[row1 + b];
    const int w00 = (256 - fx) * (256 - fy), w10 = fx * (256 - fy);
    const int w01 = (256 - fx) * fy, w11 = fx * fy;
    auto mix = [&](std::uint8_t Yuv::*channel) {
      return static_cast<std::uint8_t>((w00 * (p00.*channel) + w10 * (p10.*channel) +
                                        w01 * (p01.*channel) + w11 * (p11.*channel) + 32768) >>
                                       16);
    };
    frame_[i] = Yuv{mix(&Yuv::y), mix(&Yuv::u), mix(&Yuv::v)};
  }
}

bool SimRenderer::objectBounds(double centre_bearing, double half_span, double near, double far,
                               double top, std::array<int, 4>& bounds) const {
  const MirrorParams& m = mirror_.params();
  // The object's foot, 2 px closer for rounding; nothing to draw beyond the distance function.
  const double r_near = m.distance.imageRadius(near, centre_bearing);
  if (!std::isfinite(r_near) || r_near - 2.0 > m.outer_radius) return false;
  const double r_in = std::max(m.self_radius, r_near - 2.0);
  double r_out = m.outer_radius;
  if (top < m.reference_height) {
    const double projected = far * m.reference_height / (m.reference_height - top);
    const double r = m.distance.imageRadius(projected, centre_bearing);
    if (std::isfinite(r)) r_out = std::min(r_out, r + 2.0);
  }
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  constexpr int kSteps = 8;
  for (int k = 0; k <= kSteps; ++k) {
    const double b = centre_bearing - half_span + 2.0 * half_span * k / kSteps;
    const Vec2 dir = mirror_.imageDirection(b);
    for (const double r : {r_in, r_out}) {
      const Vec2 p = m.centre + r * dir;
      u0 = std::min(u0, p.x());
      u1 = std::max(u1, p.x());
      v0 = std::min(v0, p.y());
      v1 = std::max(v1, p.y());
    }
  }
  // The arc between samples bulges outward by at most r (1 - cos(step / 2)); pad for it.
  const double pad = 2.0 + r_out * (1.0 - std::cos(half_span / kSteps));
  bounds = {std::max(0, static_cast<int>(std::floor(u0 - pad))),
            std::max(0, static_cast<int>(std::floor(v0 - pad))),
            std::min(mirror_.width(), static_cast<int>(std::ceil(u1 + pad)) + 1),
            std::min(mirror_.height(), static_cast<int>(std::ceil(v1 + pad)) + 1)};
  return bounds[0] < bounds[2] && bounds[1] < bounds[3];
}

void SimRenderer::renderRobot(const geometry::Pose2& pose, const SimRobot& robot) {
  const Vec2 c = geometry::pointFieldToRobot(pose, robot.position);
  const double d = c.norm();
  const double rho = robot.radius;
  const double self_distance = mirror_.params().distance.floorDistance(mirror_.params().self_radius,
                                                                       std::atan2(c.y(), c.x()));
  if (d - rho <= self_distance) return;  // overlapping the own robot: nothing sensible to show
  const double bearing = std::atan2(c.y(), c.x());
  std::array<int, 4> b{};
  if (!objectBounds(bearing, std::asin(std::min(1.0, rho / d)), d - rho, d + rho,
                    params_.robot_height, b)) {
    return;
  }
  const double H = mirror_.params().reference_height;
  const double top = params_.robot_height;
  const Yuv body = lit(robot.body_colour.value_or(params_.robot), robot.position);
  const Yuv top_colour = lit(
      robot.body_colour ? scaleBgr(*robot.body_colour, 1.08) : params_.robot_top, robot.position);
  const Yuv marker = lit(
      robot.marker_colour.value_or(robot.teammate ? params_.own_marker : params_.opponent_marker),
      robot.position);
  const double s_top = top < H ? 1.0 - top / H : -1.0;
  const int w = mirror_.width();
  for (int v = b[1]; v < b[3]; ++v) {
    for (int u = b[0]; u < b[2]; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      if (kind_[i] != PixelKind::kFloor && kind_[i] != PixelKind::kHall) continue;
      const Vec2 q(floor_x_[i], floor_y_[i]);
      // Horizontal entry into the cylinder: |s q - c| = rho.
      const double a = q.squaredNorm();
      const double bq = q.dot(c);
      const double disc = bq * bq - a * (c.squaredNorm() - rho * rho);
      if (disc < 0.0) continue;
      const double s1 = (bq - std::sqrt(disc)) / a;
      if (s1 < 0.0 || s1 > 1.0) continue;
      const double z = H * (1.0 - s1);
      if (z <= top) {
        const bool band = z >= params_.marker_band[0] && z <= params_.marker_band[1];
        frame_[i] = band ? marker : body;
      } else if (s_top >= s1 && s_top <= 1.0 && (s_top * q - c).norm() <= rho) {
        frame_[i] = top_colour;
      }
    }
  }
}

void SimRenderer::renderBall(const geometry::Pose2& pose, const SimBall& ball) {
  const Vec2 c2 = geometry::pointFieldToRobot(pose, ball.position);
  const double d = c2.norm();
  const double rb = ball.radius;
  const double bearing = std::atan2(c2.y(), c2.x());
  if (d - rb <= mirror_.params().distance.floorDistance(mirror_.params().self_radius, bearing)) {
    return;
  }
  std::array<int, 4> b{};
  if (!objectBounds(bearing, std::asin(std::min(1.0, rb / d)), d - rb, d + rb, 2.0 * rb, b)) {
    return;
  }
  const double H = mirror_.params().reference_height;
  const Eigen::Vector3d centre(c2.x(), c2.y(), rb);
  const Eigen::Vector3d origin(0.0, 0.0, H);
  const Eigen::Vector3d w0 = origin - centre;
  const double light = params_.lighting.at(ball.position, carpet_half_);
  const int w = mirror_.width();
  for (int v = b[1]; v < b[3]; ++v) {
    for (int u = b[0]; u < b[2]; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      if (kind_[i] != PixelKind::kFloor && kind_[i] != PixelKind::kHall) continue;
      const Eigen::Vector3d dir(floor_x_[i], floor_y_[i], -H);
      const double a = dir.squaredNorm();
      const double bh = dir.dot(w0);
      const double disc = bh * bh - a * (w0.squaredNorm() - rb * rb);
      if (disc < 0.0) continue;
      const double s = (-bh - std::sqrt(disc)) / a;
      if (s < 0.0 || s > 1.0) continue;
      const Eigen::Vector3d normal = (origin + s * dir - centre) / rb;
      // Lit from above: the top of the ball bright, its sides darker.
      const double shade = 0.55 + 0.45 * std::max(0.0, normal.z());
      frame_[i] = yuvFromBgr(scaleBgr(params_.ball, light * shade));
    }
  }
}

void SimRenderer::renderBox(const geometry::Pose2& pose, const Box& box) {
  // Footprint seen from the robot: bearing span and near/far distances.
  const Vec2 corners[4] = {{box.lo.x(), box.lo.y()},
                           {box.hi.x(), box.lo.y()},
                           {box.hi.x(), box.hi.y()},
                           {box.lo.x(), box.hi.y()}};
  const Vec2 robot = pose.position();
  const Vec2 nearest = robot.cwiseMax(corners[0]).cwiseMin(corners[2]);
  const double near = (nearest - robot).norm();
  if (near < 1e-3) return;  // standing inside the box
  const Vec2 centre_field = 0.5 * (corners[0] + corners[2]);
  const Vec2 centre = geometry::pointFieldToRobot(pose, centre_field);
  const double centre_bearing = std::atan2(centre.y(), centre.x());
  double half_span = 0.0;
  double far = 0.0;
  for (const Vec2& corner : corners) {
    const Vec2 r = geometry::pointFieldToRobot(pose, corner);
    half_span =
        std::max(half_span, std::abs(std::remainder(std::atan2(r.y(), r.x()) - centre_bearing,
                                                    2.0 * std::numbers::pi)));
    far = std::max(far, r.norm());
  }
  std::array<int, 4> b{};
  if (!objectBounds(centre_bearing, half_span, near, far, box.hi.z(), b)) return;

  const double H = mirror_.params().reference_height;
  const Yuv side = lit(box.colour, centre_field);
  const Yuv top = lit(scaleBgr(box.colour, 1.08), centre_field);
  const double c = std::cos(pose.phi);
  const double s = std::sin(pose.phi);
  const int w = mirror_.width();
  for (int v = b[1]; v < b[3]; ++v) {
    for (int u = b[0]; u < b[2]; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      if (kind_[i] != PixelKind::kFloor && kind_[i] != PixelKind::kHall) continue;
      // The ray from the reference point to the pixel's floor point, in the field frame.
      const double x = floor_x_[i];
      const double y = floor_y_[i];
      const Eigen::Vector3d dir(c * x - s * y, s * x + c * y, -H);
      const Eigen::Vector3d origin(pose.x, pose.y, H);
      double t0 = 0.0;
      double t1 = 1.0;
      int entry_axis = -1;
      bool hit = true;
      for (int k = 0; k < 3 && hit; ++k) {
        if (std::abs(dir[k]) < 1e-12) {
          hit = origin[k] >= box.lo[k] && origin[k] <= box.hi[k];
          continue;
        }
        double a = (box.lo[k] - origin[k]) / dir[k];
        double bb = (box.hi[k] - origin[k]) / dir[k];
        if (a > bb) std::swap(a, bb);
        if (a > t0) {
          t0 = a;
          entry_axis = k;
        }
        t1 = std::min(t1, bb);
        hit = t0 <= t1;
      }
      if (hit && entry_axis >= 0) frame_[i] = entry_axis == 2 ? top : side;
    }
  }
}

void SimRenderer::renderOnce(const geometry::Pose2& robot_pose, const SimScene& scene) {
  // The mirror sees from its axis: every ray below starts there, not at the robot's centre.
  const Vec2 offset = mirror_.params().axis_offset;
  const geometry::Pose2 pose =
      geometry::poseRobotToField(robot_pose, geometry::Pose2{offset.x(), offset.y(), 0.0});
  std::copy(static_layer_.begin(), static_layer_.end(), frame_.begin());
  renderFloor(pose);

  // Painter's order: far objects first, nearer ones drawn over them.
  struct Item {
    double distance;
    int kind;  // 0 goal box, 1 robot, 2 ball, 3 scene box
    std::size_t index;
  };
  std::array<Item, 64> items{};
  std::size_t count = 0;
  const Vec2 here = pose.position();
  for (std::size_t k = 0; k < goal_boxes_.size() && count < items.size(); ++k) {
    const Vec2 mid = 0.5 * (goal_boxes_[k].lo.head<2>() + goal_boxes_[k].hi.head<2>());
    items[count++] = {(mid - here).norm(), 0, k};
  }
  for (std::size_t k = 0; k < scene.robots.size() && count < items.size(); ++k) {
    items[count++] = {(scene.robots[k].position - here).norm(), 1, k};
  }
  if (scene.ball && count < items.size()) {
    items[count++] = {(scene.ball->position - here).norm(), 2, 0};
  }
  for (std::size_t k = 0; k < scene.boxes.size() && count < items.size(); ++k) {
    const Vec2 mid = 0.5 * (scene.boxes[k].lo.head<2>() + scene.boxes[k].hi.head<2>());
    items[count++] = {(mid - here).norm(), 3, k};
  }
  std::sort(items.begin(), items.begin() + static_cast<std::ptrdiff_t>(count),
            [](const Item& a, const Item& b) { return a.distance > b.distance; });
  for (std::size_t k = 0; k < count; ++k) {
    const Item& it = items[k];
    if (it.kind == 0) {
      renderBox(pose, goal_boxes_[it.index]);
    } else if (it.kind == 1) {
      renderRobot(pose, scene.robots[it.index]);
    } else if (it.kind == 2) {
      renderBall(pose, *scene.ball);
    } else {
      renderBox(pose, scene.boxes[it.index]);
    }
  }
}

void SimRenderer::render(const SimScene& scene, std::vector<std::uint8_t>& yuyv) {
  if (!geometry::isFinite(scene.robot) || !scene.velocity.allFinite() ||
      !std::isfinite(scene.omega) || !std::isfinite(scene.exposure)) {
    throw std::invalid_argument("renderer: non-finite robot pose, velocity or exposure");
  }
  for (const SimBox& box : scene.boxes) {
    if (!box.lo.allFinite() || !box.hi.allFinite() || (box.lo.array() > box.hi.array()).any()) {
      throw std::invalid_argument("renderer: a scene box needs finite corners with lo <= hi");
    }
  }
  const std::size_t n = static_cast<std::size_t>(width()) * height();
  frame_.resize(n);
  const int samples = params_.motion_blur_samples;
  if (samples == 1 || scene.exposure <= 0.0) {
    renderOnce(scene.robot, scene);
  } else {
    accumulator_.assign(n, {0, 0, 0});
    for (int k = 0; k < samples; ++k) {
      const double t = scene.exposure * (static_cast<double>(k) / (samples - 1) - 0.5);
      const geometry::Pose2 pose{scene.robot.x + scene.velocity.x() * t,
                                 scene.robot.y + scene.velocity.y() * t,
                                 scene.robot.phi + scene.omega * t};
      renderOnce(pose, scene);
      for (std::size_t i = 0; i < n; ++i) {
        accumulator_[i][0] = static_cast<std::uint16_t>(accumulator_[i][0] + frame_[i].y);
        accumulator_[i][1] = static_cast<std::uint16_t>(accumulator_[i][1] + frame_[i].u);
        accumulator_[i][2] = static_cast<std::uint16_t>(accumulator_[i][2] + frame_[i].v);
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      frame_[i] = {static_cast<std::uint8_t>((accumulator_[i][0] + samples / 2) / samples),
                   static_cast<std::uint8_t>((accumulator_[i][1] + samples / 2) / samples),
                   static_cast<std::uint8_t>((accumulator_[i][2] + samples / 2) / samples)};
    }
  }
  realism_.apply(frame_, scene.frame_number);
  finish(scene, yuyv);
}

void SimRenderer::finish(const SimScene& scene, std::vector<std::uint8_t>& yuyv) {
  const int w = width();
  const int h = height();
  yuyv.resize(static_cast<std::size_t>(stride()) * h);
  // Noise scale in 1/256 levels per table unit.
  const int luma = static_cast<int>(std::lround(params_.noise_luma * 256.0 / kNoiseTableScale));
  const int chroma = static_cast<int>(std::lround(params_.noise_chroma * 256.0 / kNoiseTableScale));
  constexpr std::uint32_t mask = (1u << kNoiseTableBits) - 1;
  std::uint32_t state = mixSeed(params_.noise_seed, scene.frame_number);
  auto next = [&state] {
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return state;
  };
  auto noise = [&](std::uint32_t bits, int scale) {
    return (noise_table_[bits & mask] * scale) / 256;
  };
  for (int v = 0; v < h; ++v) {
    const Yuv* src = frame_.data() + static_cast<std::size_t>(v) * w;
    std::uint8_t* dst = yuyv.data() + static_cast<std::size_t>(v) * stride();
    for (int u = 0; u < w; u += 2) {
      const Yuv& a = src[u];
      const Yuv& b = src[u + 1];
      const std::uint32_t r1 = next();
      const std::uint32_t r2 = next();
      dst[2 * u + 0] = clampByte(a.y + noise(r1, luma));
      dst[2 * u + 1] = clampByte((a.u + b.u + 1) / 2 + noise(r2, chroma));
      dst[2 * u + 2] = clampByte(b.y + noise(r1 >> 16, luma));
      dst[2 * u + 3] = clampByte((a.v + b.v + 1) / 2 + noise(r2 >> 16, chroma));
    }
  }
}

// --- config ---

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
