// The simulated camera's floor: the raster built once (texture, lines and light in the field
// frame, mip levels), the per-pixel table (each pixel's floor point in the mirror axis' frame and
// its level), and the per-frame pass that rotates those points into the field and interpolates
// the raster. sim_renderer.hpp says what is rendered.
#include <algorithm>
#include <cmath>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "services/camera/sim_colour.hpp"
#include "services/camera/sim_renderer.hpp"

namespace fieldline::camera {
namespace {

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

Bgr mixBgr(Bgr a, Bgr b, double t) {
  auto m = [t](std::uint8_t x, std::uint8_t y) {
    return static_cast<std::uint8_t>(std::clamp(x + (y - x) * t + 0.5, 0.0, 255.0));
  };
  return {m(a.b, b.b), m(a.g, b.g), m(a.r, b.r)};
}

// Whether each kBlock x kBlock block of the base level's cells lies farther from every line than
// any line reaches (then its cells need no closest-line search).
//
// Most of the carpet is far from every line, and the closest-line search is most of the
// start-up time (a restarted camera should be back within a second). The distance to the lines
// changes by at most the distance moved, so one search at the centre of a block of cells
// proves the whole block uncovered when it is farther than the widest line's half width plus
// half a cell plus the block's half diagonal. The raster is unchanged, only built faster.
constexpr int kBlock = 16;
std::vector<bool> uncoveredBlocks(const field::FieldModel& field, const FloorRasterLevel& base,
                                  const Vec2& origin) {
  double max_half_width = 0.0;
  for (const auto& s : field.segments())
    max_half_width = std::max(max_half_width, 0.5 * s.width);
  for (const auto& a : field.arcs())
    max_half_width = std::max(max_half_width, 0.5 * a.width);
  const double block_half_diagonal = std::sqrt(2.0) * 0.5 * (kBlock - 1) * base.cell;
  const double uncovered_beyond = max_half_width + 0.5 * base.cell + block_half_diagonal + 1e-6;
  const int block_cols = (base.cols + kBlock - 1) / kBlock;
  std::vector<bool> uncovered(static_cast<std::size_t>(block_cols) *
                              ((base.rows + kBlock - 1) / kBlock));
  for (std::size_t b = 0; b < uncovered.size(); ++b) {
    const double bi = static_cast<double>(b % block_cols) * kBlock + 0.5 * kBlock;
    const double bj = static_cast<double>(b / block_cols) * kBlock + 0.5 * kBlock;
    const Vec2 centre = origin + Vec2(bi * base.cell, bj * base.cell);
    uncovered[b] = field.distance(centre) > uncovered_beyond;
  }
  return uncovered;
}

// Line and penalty mark coverage of the cell centred at `p` (0..1), antialiased over one cell.
double lineCoverage(const field::FieldModel& field, const Vec2& p, double cell, bool near_lines) {
  double coverage = 0.0;
  if (near_lines) {
    const field::FieldModel::Closest c = field.closestPoint(p);
    const double half_width =
        0.5 * (c.is_arc ? field.arcs()[c.element].width : field.segments()[c.element].width);
    coverage = std::clamp((half_width - c.distance) / cell + 0.5, 0.0, 1.0);
  }
  const double mark_radius = field.dimensions().penalty_mark_diameter / 2.0;
  for (const Vec2& m : field.penaltyMarks()) {
    const double d = (p - m).norm();
    coverage = std::max(coverage, std::clamp((mark_radius - d) / cell + 0.5, 0.0, 1.0));
  }
  return coverage;
}

// The next coarser mip level: 2x2 averages (the last row and column repeated when odd).
FloorRasterLevel halved(const FloorRasterLevel& fine) {
  FloorRasterLevel coarse;
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
  return coarse;
}

// One raster level's figures in the types the floor pass uses; its cells in 4x4 tiles of 4 bytes
// (floor_raster_cache.hpp, TiledLevel), tile_cols tiles a row, one cache line a tile.
struct FloorLevel {
  float inv;
  float fcols, frows;
  int cols, rows;
  const std::uint32_t* tiles;
  int tile_cols;
};

[[gnu::always_inline]] inline std::size_t tileRow(const FloorLevel& l, int j) {
  return tileRowOffset(l.tile_cols, j);
}
[[gnu::always_inline]] inline std::size_t tileColumn(int i) {
  return tileColumnOffset(i);
}

#if defined(__SSE2__)
// The bilinear mix of four cells' Y, U, V (float lanes):
// (256-fy)((256-fx)c00 + fx c10) + fy((256-fx)c01 + fx c11), rounded, / 65536.
[[gnu::always_inline]] inline Yuv mixFloat(__m128 c00, __m128 c10, __m128 c01, __m128 c11, int fx,
                                           int fy) {
  const __m128i zero = _mm_setzero_si128();
  const __m128 wx1 = _mm_set1_ps(static_cast<float>(fx));
  const __m128 wx0 = _mm_set1_ps(static_cast<float>(256 - fx));
  const __m128 top = _mm_add_ps(_mm_mul_ps(c00, wx0), _mm_mul_ps(c10, wx1));
  const __m128 bottom = _mm_add_ps(_mm_mul_ps(c01, wx0), _mm_mul_ps(c11, wx1));
  const __m128 sum =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(top, _mm_set1_ps(static_cast<float>(256 - fy))),
                            _mm_mul_ps(bottom, _mm_set1_ps(static_cast<float>(fy)))),
                 _mm_set1_ps(32768.0f));
  const __m128i shifted = _mm_srli_epi32(_mm_cvttps_epi32(sum), 16);
  const __m128i bytes = _mm_packus_epi16(_mm_packs_epi32(shifted, zero), zero);
  const auto packed = static_cast<std::uint32_t>(_mm_cvtsi128_si32(bytes));
  return Yuv{static_cast<std::uint8_t>(packed), static_cast<std::uint8_t>(packed >> 8),
             static_cast<std::uint8_t>(packed >> 16)};
}
#endif

// Each cell holds its area's mean colour at its centre; a pixel's colour is interpolated
// bilinearly between the four cell centres around its floor point. Taking the colour of the
// cell the point falls in (as until bias10i) moved a line's edges to the cells' boundaries,
// which are fixed on the field: every frame saw a line up to half a coarse cell (4-8 cm at
// 3-6 m) off, the same way, and fusion's line matching inherited a bias of 1-2 cm wherever the
// visible lines lie on one side of the robot (docs/fusion.md, tenth round).
//
// (i0, j0): the cell centre below and left of the point (-1 before the first), (fx, fy) its
// offset from there in 1/256 cell; at the raster's edge the edge cells are repeated. Four
// neighbouring cells share one tile (one cache line) nine times in sixteen, where a row-major
// raster always needs two lines, and pixels a few cells apart share tiles.
[[gnu::always_inline]] inline Yuv bilinear(const FloorLevel& l, int i0, int j0, int fx, int fy) {
  const std::size_t a = tileColumn(std::max(i0, 0));
  const std::size_t b = tileColumn(std::min(i0 + 1, l.cols - 1));
  const std::size_t row0 = tileRow(l, std::max(j0, 0));
  const std::size_t row1 = tileRow(l, std::min(j0 + 1, l.rows - 1));
#if defined(__SSE2__)
  // Y, U, V in float lanes. Exact: every product and partial sum is an integer below 2^24, and
  // (256-fy)((256-fx)p00 + fx p10) + fy((256-fx)p01 + fx p11) is the integer sum of the scalar
  // code below.
  const __m128i zero = _mm_setzero_si128();
  const auto load = [&zero](std::uint32_t cell) {
    return _mm_cvtepi32_ps(_mm_unpacklo_epi16(
        _mm_unpacklo_epi8(_mm_cvtsi32_si128(static_cast<int>(cell)), zero), zero));
  };
  return mixFloat(load(l.tiles[row0 + a]), load(l.tiles[row0 + b]), load(l.tiles[row1 + a]),
                  load(l.tiles[row1 + b]), fx, fy);
#else
  const std::uint32_t p00 = l.tiles[row0 + a];
  const std::uint32_t p10 = l.tiles[row0 + b];
  const std::uint32_t p01 = l.tiles[row1 + a];
  const std::uint32_t p11 = l.tiles[row1 + b];
  const int w00 = (256 - fx) * (256 - fy), w10 = fx * (256 - fy);
  const int w01 = (256 - fx) * fy, w11 = fx * fy;
  auto mix = [&](int shift) {
    const auto c = [shift](std::uint32_t cell) { return static_cast<int>(cell >> shift & 0xFF); };
    return static_cast<std::uint8_t>(
        (w00 * c(p00) + w10 * c(p10) + w01 * c(p01) + w11 * c(p11) + 32768) >> 16);
  };
  return Yuv{mix(0), mix(8), mix(16)};
#endif
}

// The colour at raster coordinates (gx, gy) (cells of the level, from the carpet's corner), or
// `outside` beyond the raster.
Yuv floorSample(const FloorLevel& l, float gx, float gy, Yuv outside) {
  if (!(gx >= 0.0f && gy >= 0.0f && gx < l.fcols && gy < l.frows)) return outside;
  const float cx = gx - 0.5f, cy = gy - 0.5f;
  const int i0 = cx < 0.0f ? -1 : static_cast<int>(cx);
  const int j0 = cy < 0.0f ? -1 : static_cast<int>(cy);
  const int fx = static_cast<int>((cx - static_cast<float>(i0)) * 256.0f);
  const int fy = static_cast<int>((cy - static_cast<float>(j0)) * 256.0f);
  return bilinear(l, i0, j0, fx, fy);
}

}  // namespace

// What this computes from its inputs is cached on disk (floor_raster_cache.hpp): a change here
// that gives another raster for the same inputs must bump kFloorRasterVersion.
std::vector<FloorRasterLevel> SimRenderer::buildFloorRaster(const field::FieldModel& field) const {
  FloorRasterLevel base;
  base.cell = params_.floor_resolution;
  base.inv_cell = 1.0 / base.cell;
  base.cols = static_cast<int>(std::ceil(2.0 * carpet_half_.x() / base.cell));
  base.rows = static_cast<int>(std::ceil(2.0 * carpet_half_.y() / base.cell));
  base.cells.resize(static_cast<std::size_t>(base.cols) * base.rows);

  const auto& tex = params_.carpet_texture;
  const std::vector<bool> uncovered = uncoveredBlocks(field, base, raster_origin_);
  const int block_cols = (base.cols + kBlock - 1) / kBlock;
  for (int j = 0; j < base.rows; ++j) {
    for (int i = 0; i < base.cols; ++i) {
      const Vec2 p = raster_origin_ + Vec2((i + 0.5) * base.cell, (j + 0.5) * base.cell);
      const bool near_lines =
          !uncovered[static_cast<std::size_t>(j / kBlock) * block_cols + i / kBlock];
      const double coverage = lineCoverage(field, p, base.cell, near_lines);
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
  std::vector<FloorRasterLevel> levels;
  levels.push_back(std::move(base));

  // Mip levels: 2x2 averages, until cells reach about half a metre.
  while (levels.back().cell < 0.5 && levels.back().cols > 4 && levels.back().rows > 4) {
    levels.push_back(halved(levels.back()));
  }
  return levels;
}

void SimRenderer::buildPixelTable() {
  const int w = mirror_.width();
  const int h = mirror_.height();
  const std::size_t n = static_cast<std::size_t>(w) * h;
  kind_.assign(n, PixelKind::kOutside);
  floor_x_.assign(n, 0.0f);
  floor_y_.assign(n, 0.0f);
  static_layer_.assign(n, Yuv{6, 128, 128});
  std::vector<std::uint8_t> level(n, 0);
  std::vector<std::int32_t> floor_pixels;

  const Yuv hall = yuvFromBgr(scaleBgr(params_.hall, params_.lighting.ambient));
  const double self_radius = mirror_.params().self_radius;
  const int max_level = static_cast<int>(raster_.levels().size()) - 1;
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
      const int l =
          static_cast<int>(std::lround(std::log2(footprint / params_.floor_resolution))) - 1;
      level[i] = static_cast<std::uint8_t>(std::clamp(l, 0, max_level));
      floor_pixels.push_back(static_cast<std::int32_t>(i));
    }
  }
  static_runs_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (kind_[i] == PixelKind::kFloor) continue;
    if (!static_runs_.empty() &&
        static_cast<std::size_t>(static_runs_.back()[0] + static_runs_.back()[1]) == i) {
      ++static_runs_.back()[1];
    } else {
      static_runs_.push_back({static_cast<std::int32_t>(i), 1});
    }
  }
  // Grouped by level (row-major within each), so that renderFloor reads one level's figures
  // once per run and takes the floor points four at a time.
  floor_run_x_.clear();
  floor_run_y_.clear();
  floor_run_index_.clear();
  level_end_.assign(raster_.levels().size(), 0);
  for (int l = 0; l <= max_level; ++l) {
    for (const std::int32_t i : floor_pixels) {
      if (level[static_cast<std::size_t>(i)] != l) continue;
      floor_run_x_.push_back(floor_x_[static_cast<std::size_t>(i)]);
      floor_run_y_.push_back(floor_y_[static_cast<std::size_t>(i)]);
      floor_run_index_.push_back(i);
    }
    level_end_[static_cast<std::size_t>(l)] = floor_run_index_.size();
  }
}

// --- per frame ---

Yuv SimRenderer::floorColour(const Vec2& p) const {
  const TiledLevel& l = raster_.levels().front();
  const double gx = (p.x() - raster_origin_.x()) * l.inv_cell;
  const double gy = (p.y() - raster_origin_.y()) * l.inv_cell;
  if (!(gx >= 0.0 && gy >= 0.0 && gx < l.cols && gy < l.rows)) return outside_floor_yuv_;
  return tiledCell(l, static_cast<int>(gx), static_cast<int>(gy));
}

#if defined(__SSE2__)
namespace {

// Four floor points, one a lane: where their four cells lie in the level's tiles (0 for a lane
// off the raster, which takes `outside`), their bilinear weights and which lanes lie on the raster.
struct FloorQuad {
  alignas(16) std::int32_t cell[4][4];  // corners 00, 10, 01, 11 (x then y), per lane
  __m128 fx, fy;                        // offsets in 1/256 cell (whole numbers)
  __m128i inside;                       // all ones in the lanes on the raster
};

// Lane-wise a * b for 32-bit lanes (SSE2 has no 32-bit multiply keeping the low halves).
[[gnu::always_inline]] inline __m128i mul32(__m128i a, __m128i b) {
  const __m128i even = _mm_mul_epu32(a, b);
  const __m128i odd = _mm_mul_epu32(_mm_srli_epi64(a, 32), _mm_srli_epi64(b, 32));
  return _mm_unpacklo_epi32(_mm_shuffle_epi32(even, _MM_SHUFFLE(0, 0, 2, 0)),
                            _mm_shuffle_epi32(odd, _MM_SHUFFLE(0, 0, 2, 0)));
}

// Lane-wise min and max of 32-bit lanes (SSE2 has them for 16-bit lanes only).
[[gnu::always_inline]] inline __m128i min32(__m128i a, __m128i b) {
  const __m128i a_greater = _mm_cmpgt_epi32(a, b);
  return _mm_or_si128(_mm_and_si128(a_greater, b), _mm_andnot_si128(a_greater, a));
}
[[gnu::always_inline]] inline __m128i max32(__m128i a, __m128i b) {
  const __m128i a_greater = _mm_cmpgt_epi32(a, b);
  return _mm_or_si128(_mm_and_si128(a_greater, a), _mm_andnot_si128(a_greater, b));
}

// The rotation, the bounds test and the cells of four floor points: the same float operations in
// the same order as floorSample's scalar code (SSE2 rounds each one as the scalar code does), so
// the same cells and weights; then bilinear()'s clamping at the raster's edge and tile offsets,
// lane by lane. Asks the cache for the tiles of each point's first and last cell: its four cells
// share one tile nine times in sixteen, and lie in those two in all but one case of sixteen.
[[gnu::always_inline]] inline void prepareQuad(const FloorLevel& l, const float* xs,
                                               const float* ys, __m128 vc, __m128 vs, __m128 vox,
                                               __m128 voy, FloorQuad& q) {
  const __m128 vinv = _mm_set1_ps(l.inv);
  const __m128 zero = _mm_setzero_ps(), half = _mm_set1_ps(0.5f), k256 = _mm_set1_ps(256.0f);
  const __m128 x = _mm_loadu_ps(xs);
  const __m128 y = _mm_loadu_ps(ys);
  const __m128 gx =
      _mm_mul_ps(_mm_sub_ps(_mm_add_ps(vox, _mm_mul_ps(vc, x)), _mm_mul_ps(vs, y)), vinv);
  const __m128 gy =
      _mm_mul_ps(_mm_add_ps(_mm_add_ps(voy, _mm_mul_ps(vs, x)), _mm_mul_ps(vc, y)), vinv);
  const __m128i inside = _mm_castps_si128(_mm_and_ps(
      _mm_and_ps(_mm_cmpge_ps(gx, zero), _mm_cmpge_ps(gy, zero)),
      _mm_and_ps(_mm_cmplt_ps(gx, _mm_set1_ps(l.fcols)), _mm_cmplt_ps(gy, _mm_set1_ps(l.frows)))));
  const __m128 cx = _mm_sub_ps(gx, half);
  const __m128 cy = _mm_sub_ps(gy, half);
  // Truncation, then -1 below zero: inside the raster cx >= -0.5, so this is the scalar code's
  // i0 (-1 before the first cell centre).
  const __m128i ci = _mm_add_epi32(_mm_cvttps_epi32(cx), _mm_castps_si128(_mm_cmplt_ps(cx, zero)));
  const __m128i cj = _mm_add_epi32(_mm_cvttps_epi32(cy), _mm_castps_si128(_mm_cmplt_ps(cy, zero)));
  q.fx = _mm_cvtepi32_ps(_mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(cx, _mm_cvtepi32_ps(ci)), k256)));
  q.fy = _mm_cvtepi32_ps(_mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(cy, _mm_cvtepi32_ps(cj)), k256)));
  q.inside = inside;
  // bilinear(): columns max(i0, 0) and min(i0 + 1, cols - 1), rows likewise, at their places in
  // the tiles (tileColumnOffset, tileRowOffset). Lanes off the raster read cell 0.
  const __m128i izero = _mm_setzero_si128(), one = _mm_set1_epi32(1),
                low = _mm_set1_epi32(kTileMask);
  const auto column = [&](__m128i i) {
    return _mm_add_epi32(_mm_slli_epi32(_mm_srai_epi32(i, kTileShift), 4), _mm_and_si128(i, low));
  };
  const __m128i row_stride = _mm_set1_epi32(l.tile_cols * 16);
  const auto row = [&](__m128i j) {
    return _mm_add_epi32(mul32(_mm_srai_epi32(j, kTileShift), row_stride),
                         _mm_slli_epi32(_mm_and_si128(j, low), kTileShift));
  };
  const __m128i a = column(max32(ci, izero));
  const __m128i b = column(min32(_mm_add_epi32(ci, one), _mm_set1_epi32(l.cols - 1)));
  const __m128i row0 = row(max32(cj, izero));
  const __m128i row1 = row(min32(_mm_add_epi32(cj, one), _mm_set1_epi32(l.rows - 1)));
  const __m128i c00 = _mm_and_si128(inside, _mm_add_epi32(row0, a));
  _mm_store_si128(reinterpret_cast<__m128i*>(q.cell[0]), c00);
  _mm_store_si128(reinterpret_cast<__m128i*>(q.cell[1]),
                  _mm_and_si128(inside, _mm_add_epi32(row0, b)));
  _mm_store_si128(reinterpret_cast<__m128i*>(q.cell[2]),
                  _mm_and_si128(inside, _mm_add_epi32(row1, a)));
  _mm_store_si128(reinterpret_cast<__m128i*>(q.cell[3]),
                  _mm_and_si128(inside, _mm_add_epi32(row1, b)));
  for (int lane = 0; lane < 4; ++lane) {
    _mm_prefetch(reinterpret_cast<const char*>(l.tiles + q.cell[0][lane]), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(l.tiles + q.cell[3][lane]), _MM_HINT_T0);
  }
}

// The bilinear mix of a quad's four points, one a lane, channel by channel (the byte at `shift`
// of each cell): (256-fy)((256-fx)c00 + fx c10) + fy((256-fx)c01 + fx c11), rounded, / 65536.
// Exact in float, as in the scalar code: every product and partial sum is an integer below 2^24.
[[gnu::always_inline]] inline __m128i mixChannel(__m128i c00, __m128i c10, __m128i c01, __m128i c11,
                                                 __m128 wx0, __m128 wx1, __m128 wy0, __m128 wy1,
                                                 int shift) {
  const __m128i byte = _mm_set1_epi32(0xFF);
  const auto f = [&](__m128i c) {
    return _mm_cvtepi32_ps(_mm_and_si128(_mm_srli_epi32(c, shift), byte));
  };
  const __m128 top = _mm_add_ps(_mm_mul_ps(f(c00), wx0), _mm_mul_ps(f(c10), wx1));
  const __m128 bottom = _mm_add_ps(_mm_mul_ps(f(c01), wx0), _mm_mul_ps(f(c11), wx1));
  const __m128 sum =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(top, wy0), _mm_mul_ps(bottom, wy1)), _mm_set1_ps(32768.0f));
  return _mm_srli_epi32(_mm_cvttps_epi32(sum), 16);
}

// A prepared quad's four colours (Y, U, V, 0 a lane; `outside` in the lanes off the raster).
[[gnu::always_inline]] inline __m128i mixQuad(const std::uint32_t* tiles, const FloorQuad& q,
                                              __m128i outside) {
  const auto gather = [tiles](const std::int32_t* at) {
    return _mm_setr_epi32(static_cast<int>(tiles[at[0]]), static_cast<int>(tiles[at[1]]),
                          static_cast<int>(tiles[at[2]]), static_cast<int>(tiles[at[3]]));
  };
  const __m128i c00 = gather(q.cell[0]), c10 = gather(q.cell[1]);
  const __m128i c01 = gather(q.cell[2]), c11 = gather(q.cell[3]);
  const __m128 k256 = _mm_set1_ps(256.0f);
  const __m128 wx0 = _mm_sub_ps(k256, q.fx), wy0 = _mm_sub_ps(k256, q.fy);
  const __m128i y = mixChannel(c00, c10, c01, c11, wx0, q.fx, wy0, q.fy, 0);
  const __m128i u = mixChannel(c00, c10, c01, c11, wx0, q.fx, wy0, q.fy, 8);
  const __m128i v = mixChannel(c00, c10, c01, c11, wx0, q.fx, wy0, q.fy, 16);
  const __m128i yuv = _mm_or_si128(y, _mm_or_si128(_mm_slli_epi32(u, 8), _mm_slli_epi32(v, 16)));
  return _mm_or_si128(_mm_and_si128(q.inside, yuv), _mm_andnot_si128(q.inside, outside));
}

// One level's floor points from `k` on, four at a time, into `frame`; returns where the
// quads ended (the scalar tail's start). The raster is read far apart (a few cells between
// neighbouring pixels, six cameras' rasters and the rest of the team in the caches): the cells
// of a chunk of quads are asked for while the previous chunk is mixed, so the misses overlap.
std::size_t renderFloorQuads(const FloorLevel& l, const float* xs, const float* ys,
                             const std::int32_t* index, std::size_t k, std::size_t end, float c,
                             float s, float ox, float oy, Yuv outside, Yuv* frame) {
  constexpr std::size_t kChunk = 8;  // quads
  const __m128 vc = _mm_set1_ps(c), vs = _mm_set1_ps(s);
  const __m128 vox = _mm_set1_ps(ox), voy = _mm_set1_ps(oy);
  const __m128i voutside =
      _mm_set1_epi32(static_cast<int>(outside.y | outside.u << 8 | outside.v << 16));
  const std::size_t quads = (end - k) / 4;
  FloorQuad chunk[2][kChunk];
  const auto prepare = [&](std::size_t first, FloorQuad* out) {
    const std::size_t count = std::min(kChunk, quads - first);
    for (std::size_t q = 0; q < count; ++q) {
      const std::size_t at = k + 4 * (first + q);
      prepareQuad(l, xs + at, ys + at, vc, vs, vox, voy, out[q]);
    }
  };
  if (quads > 0) prepare(0, chunk[0]);
  for (std::size_t first = 0, which = 0; first < quads; first += kChunk, which ^= 1) {
    if (first + kChunk < quads) prepare(first + kChunk, chunk[which ^ 1]);
    const std::size_t count = std::min(kChunk, quads - first);
    for (std::size_t q = 0; q < count; ++q) {
      alignas(16) std::uint32_t colour[4];
      _mm_store_si128(reinterpret_cast<__m128i*>(colour),
                      mixQuad(l.tiles, chunk[which][q], voutside));
      const std::int32_t* const pixel = index + k + 4 * (first + q);
      for (int lane = 0; lane < 4; ++lane) {
        frame[pixel[lane]] = Yuv{static_cast<std::uint8_t>(colour[lane]),
                                 static_cast<std::uint8_t>(colour[lane] >> 8),
                                 static_cast<std::uint8_t>(colour[lane] >> 16)};
      }
    }
  }
  return k + 4 * quads;
}

}  // namespace
#endif

void SimRenderer::renderFloor(const geometry::Pose2& pose) {
  const float c = static_cast<float>(std::cos(pose.phi));
  const float s = static_cast<float>(std::sin(pose.phi));
  const float ox = static_cast<float>(pose.x - raster_origin_.x());
  const float oy = static_cast<float>(pose.y - raster_origin_.y());
  Yuv* const frame = frame_.data();
  const float* const xs = floor_run_x_.data();
  const float* const ys = floor_run_y_.data();
  const std::int32_t* const index = floor_run_index_.data();
  std::size_t k = 0;
  for (std::size_t level = 0; level < level_end_.size(); ++level) {
    const TiledLevel& r = raster_.levels()[level];
    const FloorLevel l{static_cast<float>(r.inv_cell),
                       static_cast<float>(r.cols),
                       static_cast<float>(r.rows),
                       r.cols,
                       r.rows,
                       r.tiles,
                       r.tile_cols};
    const std::size_t end = level_end_[level];
#if defined(__SSE2__)
    k = renderFloorQuads(l, xs, ys, index, k, end, c, s, ox, oy, outside_floor_yuv_, frame);
#endif
    for (; k < end; ++k) {
      const float x = xs[k];
      const float y = ys[k];
      frame[index[k]] = floorSample(l, (ox + c * x - s * y) * l.inv, (oy + s * x + c * y) * l.inv,
                                    outside_floor_yuv_);
    }
  }
}

}  // namespace fieldline::camera
