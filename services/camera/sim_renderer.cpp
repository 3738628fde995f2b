#include "services/camera/sim_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <stdexcept>

#include "services/camera/sim_colour.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace fieldline::camera {
namespace {

constexpr int kNoiseTableBits = 12;

std::uint8_t clampByte(int x) {
  return static_cast<std::uint8_t>(std::clamp(x, 0, 255));
}

// One step of a sensor noise stream (Marsaglia's xorshift32).
std::uint32_t xorshift32(std::uint32_t x) {
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  return x;
}

std::uint32_t mixSeed(std::uint32_t seed, std::uint64_t frame) {
  std::uint64_t h = (frame + 1) * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(seed) << 17);
  h ^= h >> 33;
  h *= 0xFF51AFD7ED558CCDull;
  h ^= h >> 33;
  const auto out = static_cast<std::uint32_t>(h);
  return out == 0 ? 0x6D2B79F5u : out;
}

// The sensor noise's eight streams, one a lane: each its own xorshift32 from a state of its own
// (splitmix64 of the frame's seed and the lane, on one cycle of 2^32 - 1 states: two of a
// frame's lanes overlap rarely, about once in 2,000 frames at 640x480, and then only share a
// stretch of noise at an offset). Draws are taken lane 0 to 7, then every lane steps once: one SSE2
// step of four lanes gives four draws (the serial stream of one generator, until 2026-12-07,
// needed jump tables, four reads a draw; the table and so the distribution are the same).
constexpr std::size_t kNoiseLanes = 8;
std::array<std::uint32_t, kNoiseLanes> noiseLanes(std::uint32_t seed, std::uint64_t frame) {
  std::uint64_t z = static_cast<std::uint64_t>(mixSeed(seed, frame)) << 32;
  std::array<std::uint32_t, kNoiseLanes> lanes{};
  for (std::uint32_t& x : lanes) {
    z += 0x9E3779B97F4A7C15ull;
    std::uint64_t h = z;
    h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
    h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
    h ^= h >> 31;
    x = static_cast<std::uint32_t>(h ^ (h >> 32));
    if (x == 0) x = 0x6D2B79F5u;
  }
  return lanes;
}

// A sample of N(0, 1), `unit` (mean 0 and standard deviation 1 exactly), in whole levels of
// standard deviation `sigma`: each value scaled and rounded, the scale chosen (bisection) so that
// the rounded table's own standard deviation is `sigma` (rounding alone would add about 1/12
// level^2 of variance). Until 2026-12-07 the values were truncated toward zero: the sigma was
// 0.905 of the asked one for luma 3 and 0.866 for chroma 2.
std::vector<std::int16_t> noiseLevels(const std::vector<double>& unit, double sigma) {
  std::vector<std::int16_t> levels(unit.size(), 0);
  const auto fill = [&](double scale) {
    double sum = 0.0, sum2 = 0.0;
    for (std::size_t k = 0; k < unit.size(); ++k) {
      const double level = std::clamp(std::round(unit[k] * scale), -1000.0, 1000.0);
      levels[k] = static_cast<std::int16_t>(level);
      sum += level;
      sum2 += level * level;
    }
    const double n = static_cast<double>(unit.size());
    return std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
  };
  if (!(sigma > 0.0)) return levels;
  // The rounded table's sigma grows with the scale (each |level| does), in steps.
  double low = 0.0, high = 2.0 * sigma + 1.0;
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (low + high);
    (fill(mid) < sigma ? low : high) = mid;
  }
  const double below = std::abs(fill(low) - sigma);
  if (std::abs(fill(high) - sigma) > below) fill(low);
  return levels;
}

#if defined(__SSE2__)
[[gnu::always_inline]] inline __m128i xorshift32x4(__m128i x) {
  x = _mm_xor_si128(x, _mm_slli_epi32(x, 13));
  x = _mm_xor_si128(x, _mm_srli_epi32(x, 17));
  return _mm_xor_si128(x, _mm_slli_epi32(x, 5));
}
#endif

#if defined(__SSE2__)
// Two pixel pairs from `x` on as YUYV in 16-bit lanes before the noise: Y0, mean U, Y1, mean V
// each, the means (a + b + 1) / 2 (avg_epu8). Each pair is read as eight bytes from its first
// pixel: its six and two beyond (the caller stops a pair before the frame's end).
[[gnu::always_inline]] inline __m128i twoPairs(const Yuv* x) {
  const __m128i from_pixels = _mm_setr_epi8(-1, 0, 0, -1, 0, 0, 0, 0, -1, 0, 0, -1, 0, 0, 0, 0);
  std::uint64_t first = 0, second = 0;
  std::memcpy(&first, x, 8);
  std::memcpy(&second, x + 2, 8);
  const __m128i bytes =
      _mm_set_epi64x(static_cast<std::int64_t>(second), static_cast<std::int64_t>(first));
  const __m128i means = _mm_avg_epu8(bytes, _mm_srli_si128(bytes, 3));
  // Y0, mean U, mean V, Y1 in each pair's first four bytes, then in the order of YUYV.
  const __m128i picked =
      _mm_or_si128(_mm_and_si128(from_pixels, bytes), _mm_andnot_si128(from_pixels, means));
  const __m128i zero = _mm_setzero_si128();
  const __m128i low = _mm_shufflelo_epi16(_mm_unpacklo_epi8(picked, zero), _MM_SHUFFLE(2, 3, 1, 0));
  const __m128i high =
      _mm_shufflelo_epi16(_mm_unpackhi_epi8(picked, zero), _MM_SHUFFLE(2, 3, 1, 0));
  return _mm_unpacklo_epi64(low, high);
}
#endif

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

  // The sensor noise's table: 4096 draws of N(0, 1) from the seed, made mean 0 and standard
  // deviation 1, then in whole levels of the asked sigma for luma and chroma (noiseLevels).
  std::mt19937 rng(params_.noise_seed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::vector<double> unit(std::size_t{1} << kNoiseTableBits);
  double sum = 0.0, sum2 = 0.0;
  for (double& g : unit) {
    g = gauss(rng);
    sum += g;
    sum2 += g * g;
  }
  const double mean = sum / static_cast<double>(unit.size());
  const double sd = std::sqrt(sum2 / static_cast<double>(unit.size()) - mean * mean);
  for (double& g : unit)
    g = (g - mean) / sd;
  luma_noise_ = noiseLevels(unit, params_.noise_luma);
  chroma_noise_ = noiseLevels(unit, params_.noise_chroma);
}

Yuv SimRenderer::lit(Bgr colour, const Vec2& field_point) const {
  return yuvFromBgr(scaleBgr(colour, params_.lighting.at(field_point, carpet_half_)));
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
  // The floor pass writes every floor pixel: only the others come from the static layer.
  for (const auto& [first, count] : static_runs_) {
    std::copy_n(static_layer_.begin() + first, count, frame_.begin() + first);
  }
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
  // The noise: eight xorshift32 streams (noiseLanes), two draws per pixel pair (luma of both
  // pixels, then U and V), 12-bit table indices from each draw's two halves.
  std::array<std::uint32_t, kNoiseLanes> lane = noiseLanes(params_.noise_seed, scene.frame_number);
  std::size_t used = 0;
  const auto draw = [&] {
    if (used == lane.size()) {
      for (std::uint32_t& x : lane)
        x = xorshift32(x);
      used = 0;
    }
    return lane[used++];
  };
  constexpr std::uint32_t mask = (1u << kNoiseTableBits) - 1;
  // Rows follow each other without a gap (stride = 2 * width): the pixel pairs in one run.
  const std::size_t pairs = static_cast<std::size_t>(w) * h / 2;
  const Yuv* const src = frame_.data();
  std::uint8_t* const dst = yuyv.data();
  std::size_t p = 0;
#if defined(__SSE2__)
  // Four pairs take the eight lanes' draws at once (the lanes step in two vectors); sixteen
  // bytes are clamped and packed together (packus saturates to 0..255 as clampByte does). A
  // group reads two bytes beyond its last pair (twoPairs): the last group, one pair short of the
  // end at least, is left to the scalar loop.
  const std::int16_t* const luma = luma_noise_.data();
  const std::int16_t* const chroma = chroma_noise_.data();
  const __m128i index_mask = _mm_set1_epi32(static_cast<int>(mask << 16 | mask));
  __m128i low_lanes = _mm_loadu_si128(reinterpret_cast<const __m128i*>(lane.data()));
  __m128i high_lanes = _mm_loadu_si128(reinterpret_cast<const __m128i*>(lane.data() + 4));
  // Lanes r0..r3 (as 16-bit indices: r0 low, r0 high, r1 low, ...): Y0 r0, U r1, Y1 r0, V r1 of
  // the first pair, the same from r2, r3 for the second.
  const auto half = [&](const Yuv* x, __m128i r) {
    alignas(16) std::uint16_t i[8];
    _mm_store_si128(reinterpret_cast<__m128i*>(i), _mm_and_si128(r, index_mask));
    const __m128i noise = _mm_setr_epi16(luma[i[0]], chroma[i[2]], luma[i[1]], chroma[i[3]],
                                         luma[i[4]], chroma[i[6]], luma[i[5]], chroma[i[7]]);
    return _mm_add_epi16(twoPairs(x), noise);
  };
  // setScalarNoise: none of the pairs here, every one to the scalar loop.
  const std::size_t vector_pairs = scalar_noise_ ? 0 : pairs;
  for (; p + 5 <= vector_pairs; p += 4) {
    if (used == lane.size()) {
      low_lanes = xorshift32x4(low_lanes);
      high_lanes = xorshift32x4(high_lanes);
    }
    used = lane.size();
    const Yuv* const x = src + 2 * p;
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + 4 * p),
                     _mm_packus_epi16(half(x, low_lanes), half(x + 4, high_lanes)));
  }
  _mm_storeu_si128(reinterpret_cast<__m128i*>(lane.data()), low_lanes);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(lane.data() + 4), high_lanes);
#endif
  for (; p < pairs; ++p) {
    const Yuv& a = src[2 * p];
    const Yuv& b = src[2 * p + 1];
    const std::uint32_t r1 = draw();
    const std::uint32_t r2 = draw();
    std::uint8_t* const out = dst + 4 * p;
    out[0] = clampByte(a.y + luma_noise_[r1 & mask]);
    out[1] = clampByte((a.u + b.u + 1) / 2 + chroma_noise_[r2 & mask]);
    out[2] = clampByte(b.y + luma_noise_[(r1 >> 16) & mask]);
    out[3] = clampByte((a.v + b.v + 1) / 2 + chroma_noise_[(r2 >> 16) & mask]);
  }
}

}  // namespace fieldline::camera
