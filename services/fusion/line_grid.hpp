// The precomputed lookup grid layer 2 matches on (seed 4.12, "quality matrix" and force field):
// per node the distance to the nearest line centre and the seed's force (eq. 4.81-4.84), both
// interpolated bilinearly in between. The distance's gradient is the derivative of that
// interpolation, so the least-squares fit and the cost always agree.
//
// Building takes a fraction of a second for the MSL field at 2 cm, so the grid is cached on disk,
// keyed by a hash of the field's line geometry and the grid settings (in the file name and the
// header); a file that is truncated, corrupt or built for something else is rebuilt, never used.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "common/field/field_model.hpp"

namespace fieldline::fusion {

struct LineGridSettings {
  // Node spacing and how far the grid reaches beyond the lines' bounding box, m.
  double cell_m = 0.02;
  double margin_m = 1.0;
  // Force field (eq. 4.81-4.84, the seed's eta = 0.1 / cm and f_max = 150 cm in SI): weights
  // decay as exp(-decay * distance) and each element's pull is capped at `force_cap_m`.
  double force_decay_per_m = 10.0;
  double force_cap_m = 1.5;
};

// Throws std::invalid_argument unless every setting is finite and positive (margin >= 0) and
// the grid has at most 20 million nodes.
void validate(const LineGridSettings& settings);

class LineGrid {
 public:
  struct Node {
    float distance;
    float force_x;
    float force_y;
  };

  // Computes every node from the field model (exact closest points, eq. 4.74-4.78).
  static LineGrid build(const field::FieldModel& field, const LineGridSettings& settings);

  // Identifies the field geometry and the settings: equal keys mean equal grids.
  std::uint64_t key() const { return key_; }
  double cellSize() const { return cell_; }
  double originX() const { return origin_x_; }
  double originY() const { return origin_y_; }
  int columns() const { return cols_; }
  int rows() const { return rows_; }
  const std::vector<Node>& nodes() const { return nodes_; }
  const Node& node(int i, int j) const { return nodes_[static_cast<std::size_t>(j) * cols_ + i]; }

  // Interpolated distance at (x, y), and its gradient; false (outputs untouched) outside the grid
  // or for a non-finite point. Inline: this is layer 2's inner loop.
  bool distance(double x, double y, double& d) const {
    double u, v;
    int index;
    if (!locate(x, y, u, v, index)) return false;
    const float* n = &distances_[static_cast<std::size_t>(index)];
    const double d00 = n[0], d10 = n[1];
    const double d01 = n[cols_], d11 = n[cols_ + 1];
    d = (1.0 - v) * ((1.0 - u) * d00 + u * d10) + v * ((1.0 - u) * d01 + u * d11);
    return true;
  }
  bool distanceGradient(double x, double y, double& d, double& gx, double& gy) const {
    double u, v;
    int index;
    if (!locate(x, y, u, v, index)) return false;
    const float* n = &distances_[static_cast<std::size_t>(index)];
    const double d00 = n[0], d10 = n[1];
    const double d01 = n[cols_], d11 = n[cols_ + 1];
    const double bottom = (1.0 - u) * d00 + u * d10;
    const double top = (1.0 - u) * d01 + u * d11;
    d = (1.0 - v) * bottom + v * top;
    gx = ((1.0 - v) * (d10 - d00) + v * (d11 - d01)) * inv_cell_;
    gy = (top - bottom) * inv_cell_;
    return true;
  }
#if defined(__SSE2__)
  // distanceGradient() of two points at once (lanes 0 and 1), the same operations lane by lane
  // (so the same bits). Bit k of the result is set when point k lies on the grid; the outputs of
  // a lane off the grid mean nothing.
  // Always inlined: called out of line (GCC -O2 did) its outputs go through memory.
  __attribute__((always_inline)) int distanceGradient2(__m128d x, __m128d y, __m128d& d,
                                                       __m128d& gx, __m128d& gy) const {
    const __m128d inv = _mm_set1_pd(inv_cell_);
    const __m128d fx = _mm_mul_pd(_mm_sub_pd(x, _mm_set1_pd(origin_x_)), inv);
    const __m128d fy = _mm_mul_pd(_mm_sub_pd(y, _mm_set1_pd(origin_y_)), inv);
    const __m128d zero = _mm_setzero_pd();
    // As locate(): NaN fails every comparison.
    const __m128d inside = _mm_and_pd(
        _mm_and_pd(_mm_cmpge_pd(fx, zero), _mm_cmpge_pd(fy, zero)),
        _mm_and_pd(_mm_cmplt_pd(fx, _mm_set1_pd(max_u_)), _mm_cmplt_pd(fy, _mm_set1_pd(max_v_))));
    const int on = _mm_movemask_pd(inside);
    if (on == 0) return 0;
    const __m128i i = _mm_cvttpd_epi32(fx);
    const __m128i j = _mm_cvttpd_epi32(fy);
    const __m128d u = _mm_sub_pd(fx, _mm_cvtepi32_pd(i));
    const __m128d v = _mm_sub_pd(fy, _mm_cvtepi32_pd(j));
    // A lane off the grid reads node 0.
    const int index0 = (on & 1) ? _mm_cvtsi128_si32(j) * cols_ + _mm_cvtsi128_si32(i) : 0;
    const int index1 = (on & 2) ? _mm_cvtsi128_si32(_mm_shuffle_epi32(j, 1)) * cols_ +
                                      _mm_cvtsi128_si32(_mm_shuffle_epi32(i, 1))
                                : 0;
    const float* a = &distances_[static_cast<std::size_t>(index0)];
    const float* b = &distances_[static_cast<std::size_t>(index1)];
    const __m128d d00 = _mm_set_pd(b[0], a[0]), d10 = _mm_set_pd(b[1], a[1]);
    const __m128d d01 = _mm_set_pd(b[cols_], a[cols_]);
    const __m128d d11 = _mm_set_pd(b[cols_ + 1], a[cols_ + 1]);
    const __m128d one = _mm_set1_pd(1.0);
    const __m128d one_u = _mm_sub_pd(one, u), one_v = _mm_sub_pd(one, v);
    const __m128d bottom = _mm_add_pd(_mm_mul_pd(one_u, d00), _mm_mul_pd(u, d10));
    const __m128d top = _mm_add_pd(_mm_mul_pd(one_u, d01), _mm_mul_pd(u, d11));
    d = _mm_add_pd(_mm_mul_pd(one_v, bottom), _mm_mul_pd(v, top));
    gx = _mm_mul_pd(
        _mm_add_pd(_mm_mul_pd(one_v, _mm_sub_pd(d10, d00)), _mm_mul_pd(v, _mm_sub_pd(d11, d01))),
        inv);
    gy = _mm_mul_pd(_mm_sub_pd(top, bottom), inv);
    return on;
  }
#endif
  // Asks for the cache lines distance() and distanceGradient() at (x, y) will read (both node
  // rows), without waiting for them: a fit calls it a few points ahead of the one it reads, so
  // the grid's reads (most of its time in the team, where six fusions and the rest share the
  // caches) overlap the arithmetic. Changes nothing; nothing outside the grid.
  void prefetch(double x, double y) const {
    double u, v;
    int index;
    if (!locate(x, y, u, v, index)) return;
    const float* n = &distances_[static_cast<std::size_t>(index)];
    __builtin_prefetch(n);
    __builtin_prefetch(n + cols_ + 1);
  }
  // Distance and force of the node nearest to (x, y): the seed's cell lookup, a quarter of the
  // memory reads of the interpolation.
  bool nearestForce(double x, double y, double& d, double& fx, double& fy) const {
    const double gx = (x - origin_x_) * inv_cell_ + 0.5;
    const double gy = (y - origin_y_) * inv_cell_ + 0.5;
    if (!(gx >= 0.0 && gy >= 0.0 && gx < max_u_ + 1.0 && gy < max_v_ + 1.0)) return false;
    const Node& n =
        nodes_[static_cast<std::size_t>(static_cast<int>(gy)) * cols_ + static_cast<int>(gx)];
    d = n.distance;
    fx = n.force_x;
    fy = n.force_y;
    return true;
  }
  // Interpolated distance and force at (x, y).
  bool distanceForce(double x, double y, double& d, double& fx, double& fy) const {
    double u, v;
    int index;
    if (!locate(x, y, u, v, index)) return false;
    const Node* n = &nodes_[static_cast<std::size_t>(index)];
    const double w00 = (1.0 - u) * (1.0 - v), w10 = u * (1.0 - v);
    const double w01 = (1.0 - u) * v, w11 = u * v;
    const Node& a = n[0];
    const Node& b = n[1];
    const Node& c = n[cols_];
    const Node& e = n[cols_ + 1];
    d = w00 * a.distance + w10 * b.distance + w01 * c.distance + w11 * e.distance;
    fx = w00 * a.force_x + w10 * b.force_x + w01 * c.force_x + w11 * e.force_x;
    fy = w00 * a.force_y + w10 * b.force_y + w01 * c.force_y + w11 * e.force_y;
    return true;
  }

 private:
  friend std::optional<LineGrid> loadLineGrid(const std::string&, std::uint64_t, std::string*);

  // Cell coordinates of (x, y): index of its lower-left node and the fractions within the cell.
  bool locate(double x, double y, double& u, double& v, int& index) const {
    const double gx = (x - origin_x_) * inv_cell_;
    const double gy = (y - origin_y_) * inv_cell_;
    // Written so that NaN fails the test.
    if (!(gx >= 0.0 && gy >= 0.0 && gx < max_u_ && gy < max_v_)) return false;
    const int i = static_cast<int>(gx);
    const int j = static_cast<int>(gy);
    u = gx - i;
    v = gy - j;
    index = j * cols_ + i;
    return true;
  }
  void setGeometry(double cell, double origin_x, double origin_y, int cols, int rows);
  // Copies the nodes' distances into distances_ (after the nodes are set).
  void indexDistances();

  std::uint64_t key_ = 0;
  double cell_ = 0.0;
  double inv_cell_ = 0.0;
  double origin_x_ = 0.0;
  double origin_y_ = 0.0;
  int cols_ = 0;
  int rows_ = 0;
  // The last node row and column only serve as upper neighbours.
  double max_u_ = 0.0;
  double max_v_ = 0.0;
  std::vector<Node> nodes_;
  // The nodes' distances alone, for distance() and distanceGradient(): a third of the memory
  // the fit's reads touch (six fusions' grids and the rest of the team share the caches).
  std::vector<float> distances_;
};

// The key a grid for this field and these settings gets (FNV-1a over the line elements'
// coordinates, the settings and the file format version).
std::uint64_t lineGridKey(const field::FieldModel& field, const LineGridSettings& settings);
// "line_grid_<16 hex digits of the key>.bin".
std::string lineGridFileName(std::uint64_t key);

// Writes the grid (header, nodes, checksum) to `path` through a temporary file and a rename, so
// processes that start together never read half a file. Throws std::runtime_error on I/O errors.
void saveLineGrid(const LineGrid& grid, const std::string& path);
// Reads a grid written by saveLineGrid; nullopt with the reason in `problem` when the file is
// missing, truncated, has a bad checksum or another key than `expected_key`.
std::optional<LineGrid> loadLineGrid(const std::string& path, std::uint64_t expected_key,
                                     std::string* problem = nullptr);

// How loadOrBuildLineGrid came by its grid.
enum class GridSource { kBuilt, kLoadedFromCache, kRebuiltBadCache };

// The grid from `cache_dir` when a valid file is there, else built (and written there when
// cache_dir is not empty; a failure to write is not an error: the grid is still right).
LineGrid loadOrBuildLineGrid(const field::FieldModel& field, const LineGridSettings& settings,
                             const std::string& cache_dir, GridSource* source = nullptr,
                             std::string* problem = nullptr);

}  // namespace fieldline::fusion
