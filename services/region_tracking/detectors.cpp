#include "services/region_tracking/detectors.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>

namespace fieldline::region_tracking {

namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Contour points are cell corners; pixel centres sit at integer coordinates, so the corner
// between pixels u-1 and u is at u - 0.5.
constexpr float kCornerToPixel = -0.5f;

// Nearest pixel coordinate; below -0.5 anything negative (outside the frame either way).
// Cheaper than std::lround, which is a library call.
inline int nearestPixel(float coordinate) {
  const float shifted = coordinate + 0.5f;
  return shifted < 0.0f ? -1 : static_cast<int>(shifted);
}
}  // namespace

// ---------------------------------------------------------------------------------------------

FloorLookup::FloorLookup(const camera::MirrorModel& mirror)
    : width_(mirror.width()),
      height_(mirror.height()),
      floor_(static_cast<std::size_t>(width_) * height_, FloorXY{kNaN, kNaN}),
      finest_metres_per_pixel_(floor_.size(), kNaN),
      centre_u_(static_cast<float>(mirror.params().centre.x())),
      centre_v_(static_cast<float>(mirror.params().centre.y())),
      self_radius_squared_(static_cast<float>((mirror.params().self_radius + 1.0) *
                                              (mirror.params().self_radius + 1.0))) {
  for (int v = 0; v < height_; ++v) {
    for (int u = 0; u < width_; ++u) {
      if (mirror.dontTouch(u, v)) continue;
      const camera::Vec2 pixel(u, v);
      const std::optional<camera::Vec2> floor = mirror.imageToRobot(pixel);
      if (!floor) continue;
      const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
      floor_[i] = {static_cast<float>(floor->x()), static_cast<float>(floor->y())};
      const camera::Vec2 mpp = mirror.metresPerPixel(pixel);
      finest_metres_per_pixel_[i] = static_cast<float>(std::min(mpp.x(), mpp.y()));
    }
  }
}

std::optional<camera::Vec2> FloorLookup::floorPoint(double u, double v) const {
  const int u0 = static_cast<int>(std::floor(u));
  const int v0 = static_cast<int>(std::floor(v));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= width_ || v0 + 1 >= height_) return std::nullopt;
  const double fu = u - u0;
  const double fv = v - v0;
  const std::size_t i = static_cast<std::size_t>(v0) * width_ + u0;
  const std::size_t corners[4] = {i, i + 1, i + width_, i + width_ + 1};
  const double weights[4] = {(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv};
  double x = 0, y = 0;
  for (int k = 0; k < 4; ++k) {
    x += weights[k] * floor_[corners[k]].x;
    y += weights[k] * floor_[corners[k]].y;
  }
  if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  return camera::Vec2(x, y);
}

bool FloorLookup::floorPoint(float u, float v, float& x, float& y) const {
  if (!(u >= 0.0f && v >= 0.0f)) return false;  // also NaN
  const int u0 = static_cast<int>(u);
  const int v0 = static_cast<int>(v);
  if (u0 + 1 >= width_ || v0 + 1 >= height_) return false;
  const float fu = u - static_cast<float>(u0);
  const float fv = v - static_cast<float>(v0);
  const FloorXY* top = &floor_[static_cast<std::size_t>(v0) * width_ + u0];
  const FloorXY* bottom = top + width_;
  const float topX = top[0].x + fu * (top[1].x - top[0].x);
  const float topY = top[0].y + fu * (top[1].y - top[0].y);
  const float bottomX = bottom[0].x + fu * (bottom[1].x - bottom[0].x);
  const float bottomY = bottom[0].y + fu * (bottom[1].y - bottom[0].y);
  x = topX + fv * (bottomX - topX);
  y = topY + fv * (bottomY - topY);
  return std::isfinite(x) && std::isfinite(y);  // a NaN corner spoils the sum
}

// ---------------------------------------------------------------------------------------------

LineDetector::LineDetector(const camera::ColourTable& table, const FloorLookup& floor,
                           const LineDetectorParams& params, int cell_size)
    : table_(table),
      floor_(floor),
      params_(params),
      cell_size_(cell_size),
      usable_words_per_row_((floor.width() + 63) / 64),
      usable_(static_cast<std::size_t>(usable_words_per_row_) * floor.height(), 0),
      run_blocks_per_row_((floor.width() >> kRunBlockShift) + 1),
      max_run_by_block_(
          static_cast<std::size_t>(run_blocks_per_row_) * ((floor.height() >> kRunBlockShift) + 1),
          0),
      // Half a cell inside the boundary (at least 2 px): the field pixels before the line.
      first_step_(-std::max(2, cell_size / 2)) {
  if (params_.sample_spacing < 1 || params_.tangent_half_span < 1 || params_.smoothing_passes < 0 ||
      params_.max_transition_pixels < 0 || params_.max_gap_pixels < 0 ||
      params_.field_confirm_pixels < 1 || cell_size < 1 ||
      !(params_.ridge_contrast == 0.0 || params_.ridge_contrast >= 1.0) ||
      params_.ridge_min_levels < 0 || params_.ridge_min_levels > 255 ||
      !(params_.sample_spacing_m >= 0.0 && params_.sample_spacing_m <= 10.0) ||
      !(params_.sample_min_px >= 0.25 && params_.sample_min_px <= 1000.0) ||
      !(params_.turn_spacing_m >= 0.0 && params_.turn_spacing_m <= 10.0) ||
      !(params_.turn_reach_m >= 0.0 && params_.turn_reach_m <= 100.0) ||
      !(params_.turn_range_m >= 0.0 && params_.turn_range_m <= 100.0) ||
      !(params_.turn_angle > 0.0 && params_.turn_angle <= 1.5) || params_.turn_span < 1 ||
      params_.turn_span > 100 ||
      !(params_.refine_range_m >= 0.0 && params_.refine_range_m <= 100.0) ||
      !(params_.refine_min_range_m >= 0.0 && params_.refine_min_range_m <= 100.0) ||
      !(params_.refine_spacing_m >= 0.0 && params_.refine_spacing_m <= 10.0) ||
      params_.refine_samples < 1 || params_.refine_samples > 64 || params_.refine_reach < 1 ||
      params_.refine_reach > 16 || !(params_.refine_turn > 0.0 && params_.refine_turn <= 3.1)) {
    throw std::invalid_argument("line detector: invalid parameters");
  }
  // The longest white run a line can give at a pixel: its width at the pixel's finest floor
  // resolution, with tolerance, + 2 px; capped so that walks fit the 8-bit steps (~110 px).
  const int runCap =
      127 - cell_size_ - 2 * params_.max_transition_pixels - params_.field_confirm_pixels - 1;
  if (runCap < 3 || first_step_ < -127) {
    throw std::invalid_argument("line detector: cells or transitions too large");
  }
  int longestRun = 0;
  for (int v = 0; v < floor.height(); ++v) {
    for (int u = 0; u < floor.width(); ++u) {
      const float metresPerPixel = floor.finestMetresPerPixel(u, v);
      if (!std::isfinite(metresPerPixel) || metresPerPixel <= 0.0f) continue;
      usable_[static_cast<std::size_t>(v) * usable_words_per_row_ + (u >> 6)] |= std::uint64_t{1}
                                                                                 << (u & 63);
      const double run = params_.width_tolerance * params_.line_width / metresPerPixel + 2;
      const int capped = static_cast<int>(std::min(run, static_cast<double>(runCap)));
      std::uint8_t& block =
          max_run_by_block_[static_cast<std::size_t>(v >> kRunBlockShift) * run_blocks_per_row_ +
                            (u >> kRunBlockShift)];
      block = static_cast<std::uint8_t>(std::max<int>(block, capped));
      longestRun = std::max(longestRun, capped);
    }
  }
  last_step_ =
      cell_size_ + longestRun + 2 * params_.max_transition_pixels + params_.field_confirm_pixels;
  stop_step_base_ =
      cell_size_ + 2 * params_.max_transition_pixels + params_.field_confirm_pixels - first_step_;
  probe_step_ = cell_size_ + 1 - first_step_;

  // The walks: nearest pixel to t * normal for t = first_step_..last_step_, repeats dropped.
  const int span = last_step_ - first_step_ + 1;
  walk_capacity_ = span;
  walks_.assign(static_cast<std::size_t>(kDirections) * span, Step{0, 0});
  walk_count_up_to_.assign(static_cast<std::size_t>(kDirections) * span, 0);
  for (int d = 0; d < kDirections; ++d) {
    // The middle of the direction's bin on the "diamond" |u| + |v| = 1 (see directionOf).
    const double p = (d + 0.5) * 4.0 / kDirections;
    const int quadrant = static_cast<int>(p);
    const double r = p - quadrant;
    double nu = 1 - r, nv = r;
    for (int q = 0; q < quadrant; ++q) {
      const double turned = -nv;  // 90 degrees, +u towards +v
      nv = nu;
      nu = turned;
    }
    const double norm = std::hypot(nu, nv);
    nu /= norm;
    nv /= norm;
    Step* walk = &walks_[static_cast<std::size_t>(d) * span];
    std::uint8_t* countUpTo = &walk_count_up_to_[static_cast<std::size_t>(d) * span];
    int count = 0;
    for (int t = first_step_; t <= last_step_; ++t) {
      const Step step{static_cast<std::int8_t>(std::floor(t * nu + 0.5)),
                      static_cast<std::int8_t>(std::floor(t * nv + 0.5))};
      if (count == 0 || step.du != walk[count - 1].du || step.dv != walk[count - 1].dv) {
        walk[count++] = step;
      }
      countUpTo[t - first_step_] = static_cast<std::uint8_t>(count);
    }
    probes_[d] = walk[countUpTo[probe_step_] - 1];
  }

  // smoothing_passes passes of 0.25/0.5/0.25 are one binomial kernel.
  smoothing_kernel_.assign(1, 1.0f);
  for (int pass = 0; pass < params_.smoothing_passes; ++pass) {
    std::vector<float> wider(smoothing_kernel_.size() + 2, 0.0f);
    for (std::size_t j = 0; j < smoothing_kernel_.size(); ++j) {
      wider[j] += 0.25f * smoothing_kernel_[j];
      wider[j + 1] += 0.5f * smoothing_kernel_[j];
      wider[j + 2] += 0.25f * smoothing_kernel_[j];
    }
    smoothing_kernel_.swap(wider);
  }
  pad_ = params_.smoothing_passes + params_.tangent_half_span;

  // The floor's Jacobian at every cell corner, by central differences half a cell each way
  // (one-sided where one side has no floor).
  jacobian_columns_ = floor.width() / cell_size_ + 1;
  jacobian_rows_ = floor.height() / cell_size_ + 1;
  jacobians_.assign(static_cast<std::size_t>(jacobian_columns_) * jacobian_rows_,
                    Jacobian{kNaN, kNaN, kNaN, kNaN, kNaN});
  const float h = 0.5f * static_cast<float>(cell_size_);
  for (int j = 0; j < jacobian_rows_; ++j) {
    for (int i = 0; i < jacobian_columns_; ++i) {
      const float u = static_cast<float>(i * cell_size_) + kCornerToPixel;
      const float v = static_cast<float>(j * cell_size_) + kCornerToPixel;
      // d(floor)/d(image) along one image axis from the points at -h, 0, +h.
      auto derivative = [&](float du, float dv, float& dx, float& dy) {
        float x0, y0, x1, y1;
        const bool before = floor_.floorPoint(u - du, v - dv, x0, y0);
        const bool after = floor_.floorPoint(u + du, v + dv, x1, y1);
        if (before && after) {
          dx = (x1 - x0) / (2 * h);
          dy = (y1 - y0) / (2 * h);
          return true;
        }
        float xc, yc;
        if (!floor_.floorPoint(u, v, xc, yc)) return false;
        if (after) {
          dx = (x1 - xc) / h;
          dy = (y1 - yc) / h;
          return true;
        }
        if (before) {
          dx = (xc - x0) / h;
          dy = (yc - y0) / h;
          return true;
        }
        return false;
      };
      Jacobian jac;
      float x, y;
      if (derivative(h, 0.0f, jac.xu, jac.yu) && derivative(0.0f, h, jac.xv, jac.yv) &&
          floor_.floorPoint(u, v, x, y)) {
        jac.range2 = x * x + y * y;
        jacobians_[static_cast<std::size_t>(j) * jacobian_columns_ + i] = jac;
      }
    }
  }
}

const LineDetector::Jacobian* LineDetector::jacobianNear(float u, float v) const {
  // Nearest cell corner: pixel u sits at corner (u + 0.5) / cell_size.
  const float inverseCell = 1.0f / static_cast<float>(cell_size_);
  const int i = nearestPixel((u - kCornerToPixel) * inverseCell);
  const int j = nearestPixel((v - kCornerToPixel) * inverseCell);
  if (i < 0 || j < 0 || i >= jacobian_columns_ || j >= jacobian_rows_) return nullptr;
  return &jacobians_[static_cast<std::size_t>(j) * jacobian_columns_ + i];
}

bool LineDetector::floorStep(float u, float v, float du, float dv, float& dx, float& dy) const {
  dx = dy = 0.0f;
  const Jacobian* near = jacobianNear(u, v);
  if (near == nullptr) return false;
  const Jacobian& jac = *near;
  const float x = jac.xu * du + jac.xv * dv;
  const float y = jac.yu * du + jac.yv * dv;
  if (!std::isfinite(x) || !std::isfinite(y)) return false;
  dx = x;
  dy = y;
  return true;
}

void LineDetector::sampleByDistance(const float* su, const float* sv, int n,
                                    std::vector<float>& positions) {
  positions.clear();
  // The floor step of every corner step of the smoothed contour (step j: corner j to j + 1).
  step_x_.resize(n);
  step_y_.resize(n);
  step_length_.resize(n);
  for (int j = 0; j < n; ++j) {
    const int after = j + 1 == n ? 0 : j + 1;
    const float u = su[j], v = sv[j];
    const float du = su[after] - u, dv = sv[after] - v;
    floorStep(u + 0.5f * du, v + 0.5f * dv, du, dv, step_x_[j], step_y_[j]);
    step_length_[j] = std::sqrt(step_x_[j] * step_x_[j] + step_y_[j] * step_y_[j]);
  }
  // Steps within turn_reach_m of a turn: the floor directions summed over the turn_span steps
  // before corner j and after it differ by more than turn_angle.
  const bool turns = params_.turn_spacing_m > 0.0 && n > 2 * params_.turn_span;
  if (turns) {
    near_turn_.assign(n, 0);
    const int span = params_.turn_span;
    const float tanTurn = static_cast<float>(std::tan(std::min(params_.turn_angle, 1.5)));
    float bx = 0, by = 0, ax = 0, ay = 0;  // sums of the steps [j - span, j) and [j, j + span)
    for (int i = 0; i < span; ++i) {
      bx += step_x_[n - span + i];
      by += step_y_[n - span + i];
      ax += step_x_[i];
      ay += step_y_[i];
    }
    const float reach = static_cast<float>(params_.turn_reach_m);
    const float range2 = static_cast<float>(params_.turn_range_m * params_.turn_range_m);
    turn_.assign(n, 0);
    bool anyTurn = false;
    for (int j = 0; j < n; ++j) {
      const float dot = bx * ax + by * ay, cross = bx * ay - by * ax;
      if ((bx != 0.0f || by != 0.0f) && (ax != 0.0f || ay != 0.0f) &&
          (dot <= 0.0f || std::abs(cross) > tanTurn * dot)) {
        const Jacobian* near = jacobianNear(su[j], sv[j]);
        if (near != nullptr && near->range2 <= range2) {  // (NaN: no)
          turn_[j] = 1;
          anyTurn = true;
        }
      }
      // Slide both windows by one step.
      const int leaving = j - span < 0 ? j - span + n : j - span;
      const int entering = j + span >= n ? j + span - n : j + span;
      bx += step_x_[j] - step_x_[leaving];
      by += step_y_[j] - step_y_[leaving];
      ax += step_x_[entering] - step_x_[j];
      ay += step_y_[entering] - step_y_[j];
    }
    // The steps within `reach` of a turning corner, forward (steps j, j + 1, ...) and backward
    // (steps j - 1, j - 2, ...): two sweeps of twice around the closed contour, each carrying the
    // floor walked since the last turn.
    if (anyTurn) {
      float walked = reach;
      for (int k = 0; k < 2 * n; ++k) {
        const int i = k < n ? k : k - n;
        if (turn_[i]) walked = 0.0f;
        if (walked < reach) near_turn_[i] = 1;
        walked += step_length_[i];
      }
      walked = reach;
      for (int k = 2 * n - 1; k >= 0; --k) {
        const int i = k < n ? k : k - n;  // step i, from corner i to corner i + 1
        if (turn_[i + 1 == n ? 0 : i + 1]) walked = 0.0f;
        if (walked < reach) near_turn_[i] = 1;
        walked += step_length_[i];
      }
    }
  }
  // Each corner step counts min(floor length / spacing, pixels / minimum pixels) samples; a
  // sample sits wherever the running count passes a whole number, at its fraction of the step.
  const float perMetre = static_cast<float>(1.0 / params_.sample_spacing_m);
  const float perMetreNearTurn =
      turns ? static_cast<float>(1.0 / params_.turn_spacing_m) : perMetre;
  const float perPixel = static_cast<float>(1.0 / params_.sample_min_px);
  float count = 0.0f;  // samples before corner j (running, fractional)
  float next = 0.0f;   // count at which the next sample falls
  for (int j = 0; j < n; ++j) {
    const int after = j + 1 == n ? 0 : j + 1;
    const float du = su[after] - su[j], dv = sv[after] - sv[j];
    const float pixels = std::sqrt(du * du + dv * dv);
    if (step_length_[j] <= 0.0f) continue;  // no floor there
    const float units =
        std::min(step_length_[j] * (turns && near_turn_[j] ? perMetreNearTurn : perMetre),
                 pixels * perPixel);
    if (units <= 0.0f) continue;
    const float end = count + units;
    while (next < end) {
      positions.push_back(static_cast<float>(j) + (next - count) / units);
      next += 1.0f;
    }
    count = end;
  }
}

// Bins of equal length on the diamond |u| + |v| = 1, counter-clockwise from +u: no atan2, and
// no bin is wider than 2 * 360 / kDirections degrees.
[[gnu::always_inline]] inline int LineDetector::directionOf(float normalU, float normalV) {
  const float sum = std::abs(normalU) + std::abs(normalV);
  float p;
  if (normalV >= 0.0f) {
    p = normalU >= 0.0f ? normalV / sum : 1.0f - normalU / sum;
  } else {
    p = normalU < 0.0f ? 2.0f - normalV / sum : 3.0f + normalU / sum;
  }
  return std::min(static_cast<int>(p * (kDirections / 4)), kDirections - 1);
}

template <camera::PixelFormat kFormat>
bool LineDetector::scan(const camera::FrameView& frame, float originU, float originV, float normalU,
                        float normalV, float& lineU, float& lineV) {
  const int ou = nearestPixel(originU);
  const int ov = nearestPixel(originV);
  // Inside the frame: one unsigned comparison per coordinate (negative ones wrap to large).
  const unsigned width = static_cast<unsigned>(frame.width);
  const unsigned height = static_cast<unsigned>(frame.height);
  const auto inFrame = [&](const int u, const int v) {
    return (static_cast<unsigned>(u) < width) & (static_cast<unsigned>(v) < height);
  };
  if (!inFrame(ou, ov)) return false;
  if (!usable(ou, ov)) return false;
  const int maxRun = maxRunAt(ou, ov);
  const int direction = directionOf(normalU, normalV);
  const std::size_t walkAt = static_cast<std::size_t>(direction) * walk_capacity_;
  const Step* walk = &walks_[walkAt];
  const std::uint8_t* countUpTo = &walk_count_up_to_[walkAt];
  // Boundaries along the edge of the view face unusable pixels: nothing to find there.
  const Step probe = probes_[direction];
  if (!inFrame(ou + probe.du, ov + probe.dv) || !usable(ou + probe.du, ov + probe.dv)) {
    return false;
  }
  // Up to `stop` steps: the cell, the longest run here, both transitions, the confirmation.
  int count = countUpTo[stop_step_base_ + maxRun];
  // The walk is a straight line: inside the frame if both ends are; else cut it where it
  // leaves (running into the cut is a miss, as running past `stop`).
  const auto inside = [&](const Step s) { return inFrame(ou + s.du, ov + s.dv); };
  if (!inside(walk[0])) return false;
  if (!inside(walk[count - 1])) {
    int within = 1;
    while (within < count && inside(walk[within]))
      ++within;
    count = within;
  }

  // Walk the normal pixel by pixel looking for: field ... [transition] line-run [transition]
  // field, keeping each pixel's brightness for the sub-pixel edges.
  constexpr int kBytesPerPixel = kFormat == camera::PixelFormat::kYuyv ? 2 : 3;
  // The origin's row; a step's pixel is found from its offsets (a multiplication costs less
  // than a table of byte offsets per walk step, which would crowd the cache).
  const std::ptrdiff_t stride = frame.stride;
  const std::uint8_t* originRow = frame.data + static_cast<std::ptrdiff_t>(ov) * stride;
  const camera::ColourClass* lookup = table_.yuvLookup().data();
  // On the stack, so that storing a brightness cannot alias the colour table's pointer (which
  // would be reloaded for every pixel). Walks have at most 255 steps (8-bit offsets).
  std::array<std::uint8_t, kMaxWalk> luma;
  // Class of step `i` of the walk; keeps its brightness in luma[i].
  const auto classAt = [&](const int i) {
    camera::Yuv yuv;
    const Step step = walk[i];
    const std::uint8_t* row = originRow + step.dv * stride;
    const int u = ou + step.du;
    if constexpr (kFormat == camera::PixelFormat::kYuyv) {
      // The pair's Y0 U Y1 V in one read from the pair's even pixel: Y at byte 0 or 2 by the
      // pixel's parity, U and V at 1 and 3.
      const unsigned odd = static_cast<unsigned>(u) & 1u;
      std::uint32_t word;
      std::memcpy(&word, row + (static_cast<std::ptrdiff_t>(u - static_cast<int>(odd)) << 1),
                  sizeof word);
      yuv = {static_cast<std::uint8_t>(word >> (odd << 4)), static_cast<std::uint8_t>(word >> 8),
             static_cast<std::uint8_t>(word >> 24)};
    } else {
      const std::uint8_t* pixel = row + static_cast<std::ptrdiff_t>(u) * kBytesPerPixel;
      yuv = camera::yuvFromBgr({pixel[0], pixel[1], pixel[2]});
    }
    luma[i] = yuv.y;
    return lookup[camera::ColourTable::index(yuv.y, yuv.u, yuv.v)];
  };
  const camera::ColourClass field_colour = params_.field_colour;
  const camera::ColourClass line_colour = params_.line_colour;
  const int maxTransition = params_.max_transition_pixels;
  // A ridge (blurred line without line-coloured pixels) may span the longest run and both
  // transitions: pixels of no class after the field may go on that long.
  const bool ridges = params_.ridge_contrast > 0.0;
  const int maxRidge = ridges ? maxRun + 2 * maxTransition : maxTransition;
  bool ridgeEligible = true;  // every pixel since the last field pixel is unclassified
  // The first ridge met: its field pixel before, peak and field pixel after. A run of the line
  // colour further along the walk wins over it (a ridge right before a line is mostly that
  // line's blurred edge with a pixel of it classified as field).
  int ridgeField = -1, ridgeAt = -1, ridgeAfter = -1;
  bool sawField = false;
  int lastField = -1, runStart = -1, runEnd = -1, transition = 0;
  int fieldAfter = -1;  // the first field pixel after the run
  int index = 0;
  bool found = false;
  bool stopped = false;  // the walk ended before its last pixel
  // Before the line: field, then at most maxTransition pixels of other classes (maxRidge of no
  // class), then the line's first pixel.
  for (; index < count; ++index) {
    const camera::ColourClass c = classAt(index);
    if (c == field_colour) {
      if (transition > 0 && ridgeEligible && ridges && ridgeAt < 0) {
        const int peak = ridgePeak(luma.data(), lastField, index);
        if (peak >= 0) {  // field - a ridge of brightness - field: a blurred line
          ridgeField = lastField;
          ridgeAt = peak;
          ridgeAfter = index;
        }
      }
      sawField = true;
      lastField = index;
      transition = 0;
      ridgeEligible = true;
    } else if (c == line_colour) {
      if (!sawField || transition > maxTransition) {
        stopped = true;
        break;
      }
      runStart = runEnd = index;
      break;
    } else if (sawField) {
      ridgeEligible = ridgeEligible && c == camera::ColourClass::kUnknown;
      ++transition;
      if (transition > (ridgeEligible ? maxRidge : maxTransition)) {
        stopped = true;
        break;
      }
    }
  }
  if (!stopped && runStart >= 0) {
    // On the line, or back on it after a hole of noise, until field pixels confirm its end.
    const int maxGap = params_.max_gap_pixels;
    const int confirm = params_.field_confirm_pixels;
    const bool endAtSelf = params_.end_at_self;
    int fieldCount = 0;  // field pixels since fieldAfter
    for (++index; index < count; ++index) {
      const camera::ColourClass c = classAt(index);
      if (c == line_colour) {
        if (fieldAfter >= 0) {  // field came between: the line ended there, another one begins
          found = true;
          break;
        }
        if (index - runEnd - 1 > maxGap) break;
        runEnd = index;
        fieldCount = 0;
        if (runEnd - runStart + 1 > maxRun) break;
      } else {
        if (c == field_colour) {
          if (fieldAfter < 0) fieldAfter = index;
          if (++fieldCount >= confirm) {  // back on the field: found
            found = true;
            break;
          }
        } else if (endAtSelf && fieldAfter < 0 &&
                   floor_.inSelf(ou + walk[index].du, ov + walk[index].dv)) {
          // The robot's own reflection right after the line: its dark edge ends the line.
          fieldAfter = index;
          found = true;
          break;
        }
        if (index - runEnd > maxTransition + confirm) break;
      }
    }
  }
  // A field pixel that the walk's end left unconfirmed still ends the line.
  if (!found && runStart >= 0 && fieldAfter >= 0 && index == count) found = true;
  if (!found && ridgeAt >= 0) {  // no line-coloured run: the ridge is the line
    lastField = ridgeField;
    runStart = runEnd = ridgeAt;
    fieldAfter = ridgeAfter;
    found = true;
  }
  const int read = std::min(index + 1, count);
  pixels_read_ += read;
  if (!found) return false;
  // Positions along the exact (unit) normal, only now that there is something to place.
  const float inverseLength = 1.0f / std::sqrt(normalU * normalU + normalV * normalV);
  walk_ = walk;
  walk_fraction_u_ = originU - static_cast<float>(ou);
  walk_fraction_v_ = originV - static_cast<float>(ov);
  walk_normal_u_ = normalU * inverseLength;
  walk_normal_v_ = normalV * inverseLength;
  const std::uint8_t peak = *std::max_element(&luma[runStart], &luma[runEnd] + 1);
  const float middle = 0.5f * (risingEdge(luma.data(), lastField, runStart, peak) +
                               fallingEdge(luma.data(), runEnd, peak, fieldAfter));
  lineU = originU + walk_normal_u_ * middle;
  lineV = originV + walk_normal_v_ * middle;
  return true;
}

int LineDetector::ridgePeak(const std::uint8_t* luma, int fieldBefore, int fieldAfter) const {
  const int peak =
      static_cast<int>(std::max_element(&luma[fieldBefore + 1], &luma[fieldAfter]) - luma);
  const int field = std::max(luma[fieldBefore], luma[fieldAfter]);
  const bool bright = luma[peak] >= params_.ridge_contrast * field &&
                      luma[peak] >= field + params_.ridge_min_levels;
  return bright ? peak : -1;
}

// Where the brightness crosses halfway between the field before the line and the line's
// brightest sample, interpolated between the two samples around the crossing.
[[gnu::always_inline]] inline float LineDetector::risingEdge(const std::uint8_t* luma, int field,
                                                             int runStart,
                                                             std::uint8_t peak) const {
  const float threshold = 0.5f * (static_cast<float>(luma[field]) + peak);
  for (int i = field; i < runStart; ++i) {
    const float a = luma[i], b = luma[i + 1];
    if (a < threshold && b >= threshold) {
      const float ta = along(i), tb = along(i + 1);
      return ta + (tb - ta) * (threshold - a) / (b - a);
    }
  }
  return 0.5f * (along(runStart - 1) + along(runStart));
}

[[gnu::always_inline]] inline float LineDetector::fallingEdge(const std::uint8_t* luma, int runEnd,
                                                              std::uint8_t peak, int field) const {
  const float threshold = 0.5f * (static_cast<float>(luma[field]) + peak);
  for (int i = runEnd; i < field; ++i) {
    const float a = luma[i], b = luma[i + 1];
    if (a >= threshold && b < threshold) {
      const float ta = along(i), tb = along(i + 1);
      return ta + (tb - ta) * (a - threshold) / (a - b);
    }
  }
  return 0.5f * (along(runEnd) + along(runEnd + 1));
}

void LineDetector::smoothedPoint(int i, float& u, float& v) const {
  // padded_u_[j] holds corner j - pad_; the kernel is centred on corner i.
  const int taps = static_cast<int>(smoothing_kernel_.size());
  const int reach = taps / 2;
  const float* pu = &padded_u_[i + pad_ - reach];
  const float* pv = &padded_v_[i + pad_ - reach];
  const float* weight = smoothing_kernel_.data();
  float su = 0, sv = 0;
  for (int j = 0; j < taps; ++j) {
    su += weight[j] * pu[j];
    sv += weight[j] * pv[j];
  }
  u = su + kCornerToPixel;
  v = sv + kCornerToPixel;
}

void LineDetector::smoothContour(const ContourPoint* corners, int n, int stride, float* su,
                                 float* sv) {
  const int smoothed = n / stride;
  if (smoothing_kernel_.size() == 7) {
    // Three passes: the kernel is 1 6 15 20 15 6 1 over 64. Summed in integers and scaled once:
    // the same points bit for bit as the float sums over the padded corners (every term there
    // is a multiple of 1/64 far below 2^24, so no float operation rounds), without the copy.
    const auto at = [&](int i) -> const ContourPoint& {
      return corners[i < 0 ? i + n * ((-i + n - 1) / n) : (i >= n ? i % n : i)];
    };
    constexpr float kScale = 1.0f / 64.0f;
    for (int j = 0; j < smoothed; ++j) {
      const int i = j * stride;
      int x, y;
      if (i >= 3 && i + 3 < n) {
        const ContourPoint* c = corners + i;
        x = (c[-3].x + c[3].x) + 6 * (c[-2].x + c[2].x) + 15 * (c[-1].x + c[1].x) + 20 * c[0].x;
        y = (c[-3].y + c[3].y) + 6 * (c[-2].y + c[2].y) + 15 * (c[-1].y + c[1].y) + 20 * c[0].y;
      } else {
        x = (at(i - 3).x + at(i + 3).x) + 6 * (at(i - 2).x + at(i + 2).x) +
            15 * (at(i - 1).x + at(i + 1).x) + 20 * at(i).x;
        y = (at(i - 3).y + at(i + 3).y) + 6 * (at(i - 2).y + at(i + 2).y) +
            15 * (at(i - 1).y + at(i + 1).y) + 20 * at(i).y;
      }
      su[j] = static_cast<float>(x) * kScale + kCornerToPixel;
      sv[j] = static_cast<float>(y) * kScale + kCornerToPixel;
    }
    return;
  }
  // Any other kernel: the corners with the kernel's and the tangent's reach wrapped around on
  // both sides.
  padded_u_.resize(n + 2 * pad_);
  padded_v_.resize(n + 2 * pad_);
  for (int j = 0; j < n; ++j) {
    padded_u_[pad_ + j] = static_cast<float>(corners[j].x);
    padded_v_[pad_ + j] = static_cast<float>(corners[j].y);
  }
  for (int j = 0; j < pad_; ++j) {  // the wrapped ends (the contour may be shorter than pad_)
    const int before = ((j - pad_) % n + n) % n;
    padded_u_[j] = static_cast<float>(corners[before].x);
    padded_v_[j] = static_cast<float>(corners[before].y);
    padded_u_[pad_ + n + j] = static_cast<float>(corners[j % n].x);
    padded_v_[pad_ + n + j] = static_cast<float>(corners[j % n].y);
  }
  for (int j = 0; j < smoothed; ++j)
    smoothedPoint(j * stride, su[j], sv[j]);
}

void LineDetector::detect(const camera::FrameView& frame, const ContourSet& contours,
                          LinePoints& out) {
  if (frame.width != floor_.width() || frame.height != floor_.height()) {
    throw std::invalid_argument("line detector: frame size differs from the floor lookup's");
  }
  out.clear();
  pixels_read_ = 0;
  scans_ = 0;
  const bool yuyv = frame.format == camera::PixelFormat::kYuyv;
  const ClassId field = classIdOf(params_.field_colour);
  const int spacing = params_.sample_spacing;
  const int k = params_.tangent_half_span;
  const bool byDistance = params_.sample_spacing_m > 0.0;
  const bool refine = !byDistance && params_.refine_range_m > 0.0;

  // Tangent (difference of the smoothed corners tangent_reach before and after) at `centre`.
  auto tangentAt = [&](const ContourWork& w, int centre, float& tu, float& tv) {
    const float* su = &smooth_u_[w.smooth_begin];
    const float* sv = &smooth_v_[w.smooth_begin];
    int ahead = centre + w.tangent_reach, behind = centre - w.tangent_reach;
    if (ahead >= w.smoothed) ahead %= w.smoothed;
    if (behind < 0) behind = (behind % w.smoothed + w.smoothed) % w.smoothed;
    tu = su[ahead] - su[behind];
    tv = sv[ahead] - sv[behind];
  };
  // One scan from (originU, originV) across the tangent (tu, tv); the hit's image position.
  auto scanAcross = [&](float originU, float originV, float tu, float tv, Hit& hit) {
    if (tu * tu + tv * tv < 1e-6f) return;
    // The region lies to the right of the walking direction on screen: outward is left. The
    // walk needs only the normal's direction; scan() normalises it when it finds a line.
    const float normalU = tv;
    const float normalV = -tu;
    float lineU = 0, lineV = 0;
    ++scans_;
    const bool found = yuyv ? scan<camera::PixelFormat::kYuyv>(frame, originU, originV, normalU,
                                                               normalV, lineU, lineV)
                            : scan<camera::PixelFormat::kBgr>(frame, originU, originV, normalU,
                                                              normalV, lineU, lineV);
    if (!found) return;
    hit = {true, {lineU, lineV, 0.0f, 0.0f}};
    floor_.prefetch(lineU, lineV);
  };
  // A scan at a fractional position among the smoothed corners (index + fraction of the step
  // after it): the curve and its tangent interpolated linearly.
  auto scanAt = [&](const ContourWork& w, float position, Hit& hit) {
    const float* su = &smooth_u_[w.smooth_begin];
    const float* sv = &smooth_v_[w.smooth_begin];
    int centre = static_cast<int>(position);
    const float f = position - static_cast<float>(centre);
    if (centre >= w.smoothed) centre -= w.smoothed;
    const int after = centre + 1 == w.smoothed ? 0 : centre + 1;
    float tu, tv, tu1, tv1;
    tangentAt(w, centre, tu, tv);
    tangentAt(w, after, tu1, tv1);
    tu += f * (tu1 - tu);
    tv += f * (tv1 - tv);
    scanAcross(su[centre] + f * (su[after] - su[centre]), sv[centre] + f * (sv[after] - sv[centre]),
               tu, tv, hit);
  };
  // The floor points of hits found by scans, looked up once the table entries prefetched at
  // each hit have had the other contours' scans to arrive (the table is large, and looking each
  // up right after its scan waited on memory for every point).
  auto toFloor = [&](Hit* hits, std::size_t count) {
    for (std::size_t i = 0; i < count; ++i) {
      Hit& hit = hits[i];
      if (hit.found)
        hit.found = floor_.floorPoint(hit.point.u, hit.point.v, hit.point.x, hit.point.y);
    }
  };

  // Pass 1, every contour: its smoothed corners and the scans at its samples.
  work_.clear();
  smooth_u_.clear();
  smooth_v_.clear();
  hits_.clear();
  for (const Contour& contour : contours.contours) {
    if (contour.class_id != field || contour.size() < params_.min_contour_points) continue;
    const int n = contour.size();
    const ContourPoint* corners = &contours.points[contour.begin];
    // The contour is a staircase of cell sides; smoothing turns it into a curve with usable
    // tangents (the seed smooths before taking differences, section 3.3). Only the corners
    // that are sampled or give a sample's tangent are smoothed: every `stride`-th one.
    const int stride = !byDistance && n % std::gcd(spacing, k) == 0 ? std::gcd(spacing, k) : 1;
    ContourWork w;
    w.smoothed = n / stride;
    w.smooth_begin = static_cast<int>(smooth_u_.size());
    smooth_u_.resize(w.smooth_begin + w.smoothed);
    smooth_v_.resize(w.smooth_begin + w.smoothed);
    float* su = &smooth_u_[w.smooth_begin];
    float* sv = &smooth_v_[w.smooth_begin];
    smoothContour(corners, n, stride, su, sv);
    if (byDistance) sampleByDistance(su, sv, n, sample_positions_);
    // Indices among the smoothed corners: no division per sample but at the contour's ends.
    w.sample_step = spacing / stride;
    w.tangent_reach = k / stride;
    w.samples = byDistance ? static_cast<int>(sample_positions_.size()) : n / spacing;
    w.hits_begin = hits_.size();
    Hit* hits = hits_.appendMisses(w.samples);
    for (int s = 0; s < w.samples; ++s) {
      if (byDistance) {
        scanAt(w, sample_positions_[s], hits[s]);
      } else {
        const int centre = s * w.sample_step;
        float tu, tv;
        tangentAt(w, centre, tu, tv);
        scanAcross(su[centre], sv[centre], tu, tv, hits[s]);
      }
    }
    work_.push_back(w);
  }
  toFloor(hits_.data(), static_cast<std::size_t>(hits_.size()));

  // Pass 2 (refine_range_m): the intervals around line points where their line ends or turns,
  // within range, scanned again; the hits of both passes in contour order in merged_hits_.
  merged_hits_.clear();
  refined_.clear();
  if (refine) {
    const float maxRange2 = static_cast<float>(params_.refine_range_m * params_.refine_range_m);
    const float minRange2 =
        static_cast<float>(params_.refine_min_range_m * params_.refine_min_range_m);
    const float cosTurn = static_cast<float>(std::cos(params_.refine_turn));
    const int reach = params_.refine_reach;
    const float perMetre =
        params_.refine_spacing_m > 0.0 ? static_cast<float>(1.0 / params_.refine_spacing_m) : 0.0f;
    for (ContourWork& w : work_) {
      const int samples = w.samples;
      if (samples < 3) continue;
      const Hit* hits = &hits_[w.hits_begin];
      refine_interval_.assign(samples, 0);
      bool any = false;
      for (int s = 0; s < samples; ++s) {
        const Hit& hit = hits[s];
        if (!hit.found) continue;
        const float range2 = hit.point.x * hit.point.x + hit.point.y * hit.point.y;
        if (range2 > maxRange2 || range2 < minRange2) continue;
        const Hit& before = hits[s == 0 ? samples - 1 : s - 1];
        const Hit& after = hits[s + 1 == samples ? 0 : s + 1];
        if (!before.found && !after.found && !params_.refine_isolated) continue;
        bool event = !before.found || !after.found;
        if (!event) {
          const float ax = hit.point.x - before.point.x, ay = hit.point.y - before.point.y;
          const float bx = after.point.x - hit.point.x, by = after.point.y - hit.point.y;
          const float dot = ax * bx + ay * by;
          event = dot <= cosTurn * std::sqrt((ax * ax + ay * ay) * (bx * bx + by * by));
        }
        if (!event) continue;
        any = true;
        // Intervals s - reach .. s + reach - 1 (interval i runs from sample i to sample i + 1).
        for (int i = s - reach; i < s + reach; ++i)
          refine_interval_[((i % samples) + samples) % samples] = 1;
      }
      if (!any) continue;
      const float* su = &smooth_u_[w.smooth_begin];
      const float* sv = &smooth_v_[w.smooth_begin];
      w.merged_begin = merged_hits_.size();
      for (int s = 0; s < samples; ++s) {
        merged_hits_.push(hits_[w.hits_begin + s]);
        if (!refine_interval_[s]) continue;
        const float a = static_cast<float>(s * w.sample_step);
        const float b = s + 1 == samples ? static_cast<float>(w.smoothed)
                                         : static_cast<float>((s + 1) * w.sample_step);
        int extra = params_.refine_samples;
        if (perMetre > 0.0f) {
          // The interval's floor length: its chord through the floor's Jacobian at its middle.
          const int ia = static_cast<int>(a), ib = s + 1 == samples ? 0 : static_cast<int>(b);
          const float du = su[ib] - su[ia], dv = sv[ib] - sv[ia];
          const float metres = floorLength(su[ia] + 0.5f * du, sv[ia] + 0.5f * dv, du, dv);
          extra = std::min(extra, static_cast<int>(metres * perMetre));
          if (extra <= 0) continue;
        }
        const int first = merged_hits_.size();
        Hit* const scanned = merged_hits_.appendMisses(extra);
        for (int t = 1; t <= extra; ++t) {
          scanAt(w, a + (b - a) * static_cast<float>(t) / static_cast<float>(extra + 1),
                 scanned[t - 1]);
        }
        refined_.emplace_back(first, extra);
      }
      w.merged_count = merged_hits_.size() - w.merged_begin;
    }
    for (const auto& [first, count] : refined_)
      toFloor(&merged_hits_[first], static_cast<std::size_t>(count));
  }

  // Group hits into sequences along each contour, starting after a miss so that a sequence
  // crossing the contour's start is not cut in two.
  for (const ContourWork& w : work_) {
    const bool merged = w.merged_begin >= 0;
    const Hit* ordered = merged ? &merged_hits_[w.merged_begin] : &hits_[w.hits_begin];
    const int total = merged ? w.merged_count : w.samples;
    int firstMiss = -1;
    for (int s = 0; s < total && firstMiss < 0; ++s) {
      if (!ordered[s].found) firstMiss = s;
    }
    const int begin = firstMiss < 0 ? 0 : firstMiss;
    int sequenceStart = -1;
    int misses = 0;
    auto close = [&] {
      const int end = static_cast<int>(out.points.size());
      if (sequenceStart >= 0 && end - sequenceStart >= 2) {
        out.sequences.emplace_back(sequenceStart, end);
      } else if (sequenceStart >= 0) {
        out.points.resize(sequenceStart);  // a lone point is more likely noise than a line
      }
      sequenceStart = -1;
    };
    // From `begin` round to it: no division per hit.
    for (int step = 0, at = begin; step < total; ++step, at = at + 1 == total ? 0 : at + 1) {
      const Hit& hit = ordered[at];
      if (hit.found) {
        if (sequenceStart < 0) sequenceStart = static_cast<int>(out.points.size());
        out.points.push_back(hit.point);
        misses = 0;
      } else if (sequenceStart >= 0 && ++misses > params_.max_gap_samples) {
        close();
      }
    }
    close();
  }
}

// ---------------------------------------------------------------------------------------------

BallDetector::BallDetector(const camera::ColourTable& table, const camera::MirrorModel& mirror,
                           const BallParams& params)
    : table_(table), mirror_(mirror), params_(params) {
  if (!(params_.size_tolerance >= 1.0) || !(params_.size_slack_px >= 0.0) ||
      !(params_.min_fill >= 0.0 && params_.min_fill <= 1.0) ||
      !(params_.min_carpet_share >= 0.0 && params_.min_carpet_share <= 1.0) ||
      !(params_.centre_height > 0.0 &&
        params_.centre_height < 0.5 * mirror_.params().reference_height) ||
      params_.min_pixels < 1) {
    throw std::invalid_argument("ball detector: invalid parameters");
  }
  // The ball is largest in the image next to the robot: the largest extent of a ball at the
  // edge of the robot's own reflection and a little beyond, in a few directions.
  const double nearest = mirror_.params().distance.floorDistance(
      mirror_.params().self_radius, 0.0);  // floor distance at the self radius
  for (int k = 0; k < 8; ++k) {
    const double bearing = k * std::numbers::pi / 4;
    for (double d = std::max(nearest, 0.0) + params_.centre_height; d < 2.0; d += 0.05) {
      double radial = 0, tangential = 0;
      if (expectedExtent(d, bearing, radial, tangential)) {
        max_extent_px_ = std::max({max_extent_px_, radial, tangential});
      }
    }
  }
  if (max_extent_px_ <= 0) throw std::invalid_argument("ball detector: no ball is visible");
  const std::vector<camera::ColourClass>& cells = table_.yuvLookup();
  has_colour_ = std::find(cells.begin(), cells.end(), params_.colour) != cells.end();
}

bool BallDetector::expectedExtent(double horizontal, double bearing, double& radialPx,
                                  double& tangentialPx) const {
  // Every point of the sphere projects inside its silhouette and the silhouette's rim is made of
  // sphere points: the extents of the projected surface points are the silhouette's.
  const double r = params_.centre_height;
  // `horizontal` and `bearing` are about the mirror axis; the 3-D projection takes robot-frame
  // points.
  const camera::Vec2 xy =
      mirror_.axisToRobot(horizontal * camera::Vec2(std::cos(bearing), std::sin(bearing)));
  const camera::Vec3 centre(xy.x(), xy.y(), r);
  const std::optional<camera::Vec2> centrePixel = mirror_.robotPointToImage(centre);
  if (!centrePixel) return false;
  const double centreBearing = mirror_.bearingOf(*centrePixel);
  const double centreRadius = mirror_.radiusOf(*centrePixel);
  double nearR = std::numeric_limits<double>::infinity(), farR = 0, minOff = 0, maxOff = 0;
  constexpr int kPolar = 8, kAzimuth = 16;
  for (int i = 0; i <= kPolar; ++i) {
    const double theta = std::numbers::pi * i / kPolar;
    for (int j = 0; j < (i == 0 || i == kPolar ? 1 : kAzimuth); ++j) {
      const double phi = 2 * std::numbers::pi * j / kAzimuth;
      const camera::Vec3 p =
          centre + r * camera::Vec3(std::sin(theta) * std::cos(phi),
                                    std::sin(theta) * std::sin(phi), std::cos(theta));
      const std::optional<camera::Vec2> pixel = mirror_.robotPointToImage(p);
      if (!pixel) return false;
      const double radius = mirror_.radiusOf(*pixel);
      nearR = std::min(nearR, radius);
      farR = std::max(farR, radius);
      const double offset =
          std::remainder(mirror_.bearingOf(*pixel) - centreBearing, 2 * std::numbers::pi);
      minOff = std::min(minOff, offset);
      maxOff = std::max(maxOff, offset);
    }
  }
  radialPx = farR - nearR;
  tangentialPx = (maxOff - minOff) * centreRadius;
  return true;
}

namespace {
// How well a measured extent agrees with the expected one, in (0, 1].
double agreement(double measured, double expected) {
  return (std::min(measured, expected) + 1.0) / (std::max(measured, expected) + 1.0);
}
}  // namespace

BallReject BallDetector::evaluate(const camera::FrameView& frame, const ContourSet& contours,
                                  const Contour& contour, BallDetection& out,
                                  const BallRegion* region) const {
  out = BallDetection{};
  int minU = frame.width, minV = frame.height, maxU = 0, maxV = 0;
  for (const ContourPoint& p : contours.pointsOf(contour)) {
    minU = std::min(minU, p.x);
    maxU = std::max(maxU, p.x);
    minV = std::min(minV, p.y);
    maxV = std::max(maxV, p.y);
  }
  // The region's box is in whole cells; a ball's image is never much larger than the largest
  // ball image plus a cell on each side.
  const double largest = max_extent_px_ * params_.size_tolerance + params_.size_slack_px + 8.0;
  if (maxU - minU > largest || maxV - minV > largest) return BallReject::kTooLarge;
  // Cut by the image's border: its size says nothing (a cut box can look like a ball).
  if (minU <= 0 || minV <= 0 || maxU >= frame.width || maxV >= frame.height) {
    return BallReject::kAtImageBorder;
  }
  minU = std::max(0, minU - 1);
  minV = std::max(0, minV - 1);
  maxU = std::min(frame.width, maxU + 1);
  maxV = std::min(frame.height, maxV + 1);

  // The ball is a sphere seen from the mirror's reference point R: its image stretches
  // radially from the ray grazing its near side to the ray grazing its far side, and the ray to
  // its centre halves the angle between those two (seed 4.9.5). So take the nearest and
  // farthest orange pixel radius (the centroid would be pulled outward), and the bearing from
  // the centroid of the orange pixels.
  const camera::Vec2 centre = mirror_.params().centre;
  double sumU = 0, sumV = 0;
  double nearRadius = std::numeric_limits<double>::infinity(), farRadius = 0;
  int pixels = 0;
  for (int v = minV; v < maxV; ++v) {
    for (int u = minU; u < maxU; ++u) {
      if (table_.classifyPixel(frame, u, v) != params_.colour) continue;
      sumU += u;
      sumV += v;
      ++pixels;
      const double radius = std::hypot(u - centre.x(), v - centre.y());
      nearRadius = std::min(nearRadius, radius);
      farRadius = std::max(farRadius, radius);
    }
  }
  if (pixels < params_.min_pixels) return BallReject::kTooFewPixels;
  const camera::Vec2 centroid(sumU / pixels, sumV / pixels);
  const double bearing = mirror_.bearingOf(centroid);
  const camera::DistanceFunction& distance = mirror_.params().distance;
  // Half a pixel beyond the outermost pixel centres on both sides.
  const double nearFloor = distance.floorDistance(std::max(0.0, nearRadius - 0.5), bearing);
  const double farFloor = distance.floorDistance(farRadius + 0.5, bearing);
  if (!std::isfinite(nearFloor) || !std::isfinite(farFloor)) return BallReject::kNoFloor;
  const double H = mirror_.params().reference_height;
  // Depression angles of the two grazing rays from R; the centre ray lies midway.
  const double centreAngle = 0.5 * (std::atan2(H, nearFloor) + std::atan2(H, farFloor));
  const double centreFloor = H / std::tan(centreAngle);
  const double lift = (H - params_.centre_height) / H;
  const double horizontal = centreFloor * lift;
  // All of this is about the mirror axis (its rays start there): move to the robot frame last.
  const camera::Vec2 direction = camera::Vec2(std::cos(bearing), std::sin(bearing));
  const camera::Vec2 centreXY = mirror_.axisToRobot(direction * horizontal);
  const std::optional<camera::Vec2> centrePixel = mirror_.axisToImage(direction * centreFloor);
  if (!centrePixel) return BallReject::kNoFloor;
  // Where the field model says a ball can be: on the field, seen from fusion's pose.
  if (region && region->field) {
    const geometry::Vec2 onField = geometry::pointRobotToField(region->pose, centreXY);
    if (!region->field->insideLines(onField, params_.field_margin_m + region->pose_sigma_m)) {
      return BallReject::kOutsideField;
    }
  }

  // Size and shape: what a ball there would look like (3-D mirror model) against the pixels.
  double expectedRadial = 0, expectedTangential = 0;
  if (!expectedExtent(horizontal, bearing, expectedRadial, expectedTangential)) {
    return BallReject::kNoFloor;
  }
  double minOffset = 0, maxOffset = 0;
  for (int v = minV; v < maxV; ++v) {
    for (int u = minU; u < maxU; ++u) {
      if (table_.classifyPixel(frame, u, v) != params_.colour) continue;
      const double offset =
          std::remainder(mirror_.bearingOf(camera::Vec2(u, v)) - bearing, 2 * std::numbers::pi);
      minOffset = std::min(minOffset, offset);
      maxOffset = std::max(maxOffset, offset);
    }
  }
  // Extents over pixel centres, plus the pixel itself.
  const double radialPx = farRadius - nearRadius + 1;
  const double tangentialPx = (maxOffset - minOffset) * mirror_.radiusOf(centroid) + 1;
  const double tol = params_.size_tolerance, slack = params_.size_slack_px;
  auto fits = [&](double measured, double expected) {
    return measured <= expected * tol + slack && measured >= expected / tol - slack;
  };
  if (!fits(radialPx, expectedRadial) || !fits(tangentialPx, expectedTangential)) {
    return BallReject::kSize;
  }
  const double silhouette = std::numbers::pi / 4 * (expectedRadial + 1) * (expectedTangential + 1);
  const double fill = pixels / silhouette;
  if (fill < params_.min_fill) return BallReject::kFill;

  // On the carpet: a ring of samples around the candidate, 1.5 times its expected size + 2 px.
  const camera::Vec2 radialAxis = (centroid - centre).normalized();
  const camera::Vec2 tangentialAxis(-radialAxis.y(), radialAxis.x());
  const double ringRadial = 0.75 * expectedRadial + 2.0;
  const double ringTangential = 0.75 * expectedTangential + 2.0;
  constexpr int kRingSamples = 16;
  int usable = 0, carpet = 0;
  for (int k = 0; k < kRingSamples; ++k) {
    const double a = 2 * std::numbers::pi * k / kRingSamples;
    const camera::Vec2 p = centroid + radialAxis * (std::cos(a) * ringRadial) +
                           tangentialAxis * (std::sin(a) * ringTangential);
    const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
    if (!frame.contains(u, v) || mirror_.zone(camera::Vec2(u, v)) == camera::MirrorZone::kSelf ||
        mirror_.zone(camera::Vec2(u, v)) == camera::MirrorZone::kOutside) {
      continue;  // no floor to see there (the robot's own reflection, outside the mirror)
    }
    ++usable;
    const camera::ColourClass c = table_.classifyPixel(frame, u, v);
    if (c == params_.field_colour || c == params_.line_colour) ++carpet;
  }
  const double carpetShare = usable > 0 ? static_cast<double>(carpet) / usable : 0.0;
  if (usable < kRingSamples / 2 || carpetShare < params_.min_carpet_share) {
    return BallReject::kNotOnCarpet;
  }

  out.visible = true;
  out.u = centrePixel->x();
  out.v = centrePixel->y();
  out.x = centreXY.x();
  out.y = centreXY.y();
  out.pixels = pixels;
  out.cells = contour.signed_cell_area;
  // Half a pixel of centroid error, scaled to the floor and lifted to the ball's height.
  const camera::Vec2 mpp = mirror_.metresPerPixel(*centrePixel);
  out.sigma_radial = 0.5 * mpp.x() * lift;
  out.sigma_tangential = 0.5 * mpp.y() * lift;
  out.confidence = carpetShare * std::min(fill, 1.0) * agreement(radialPx, expectedRadial + 1) *
                   agreement(tangentialPx, expectedTangential + 1);
  return BallReject::kNone;
}

BallDetection BallDetector::detect(const camera::FrameView& frame, const ContourSet& contours,
                                   const BallRegion* region) const {
  BallDetection best;
  int candidates = 0, rejected = 0;
  const ClassId orange = classIdOf(params_.colour);
  BallDetection candidate;
  for (const Contour& contour : contours.contours) {
    if (contour.class_id != orange || !contour.outer) continue;
    ++candidates;
    if (evaluate(frame, contours, contour, candidate, region) != BallReject::kNone) {
      ++rejected;
      continue;
    }
    if (!best.visible || candidate.confidence > best.confidence) best = candidate;
  }
  best.candidates = candidates;
  best.rejected = rejected;
  return best;
}

// ---------------------------------------------------------------------------------------------

ObstacleDetector::ObstacleDetector(const camera::MirrorModel& mirror, const ObstacleParams& params)
    : mirror_(mirror), params_(params) {}

void ObstacleDetector::detect(const ContourSet& contours, std::vector<Obstacle>& out) const {
  out.clear();
  const ClassId black = classIdOf(params_.colour);
  for (const Contour& contour : contours.contours) {
    if (contour.class_id != black || !contour.outer ||
        contour.signed_cell_area < params_.min_cells) {
      continue;
    }
    // The foot of an object standing on the floor is its point nearest the image centre;
    // its angular extent is the spread of bearings around the first point.
    camera::Vec2 nearest;
    double nearestRadius = std::numeric_limits<double>::infinity();
    double firstBearing = 0, minOffset = 0, maxOffset = 0;
    bool first = true;
    for (const ContourPoint& p : contours.pointsOf(contour)) {
      const camera::Vec2 pixel(p.x + kCornerToPixel, p.y + kCornerToPixel);
      const double bearing = mirror_.bearingOf(pixel);
      if (first) {
        firstBearing = bearing;
        first = false;
      }
      const double offset = std::remainder(bearing - firstBearing, 2 * std::numbers::pi);
      minOffset = std::min(minOffset, offset);
      maxOffset = std::max(maxOffset, offset);
      const double radius = mirror_.radiusOf(pixel);
      if (radius < nearestRadius) {
        nearestRadius = radius;
        nearest = pixel;
      }
    }
    const std::optional<camera::Vec2> foot = mirror_.imageToRobot(nearest);
    if (!foot) continue;
    Obstacle obstacle;
    obstacle.distance = foot->norm();
    obstacle.x = foot->x();
    obstacle.y = foot->y();
    obstacle.angular_width = maxOffset - minOffset;
    obstacle.bearing =
        std::remainder(firstBearing + 0.5 * (minOffset + maxOffset), 2 * std::numbers::pi);
    obstacle.width = 2.0 * obstacle.distance * std::tan(0.5 * obstacle.angular_width);
    out.push_back(obstacle);
  }
}

}  // namespace fieldline::region_tracking
