#include "services/fusion/line_grid.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <system_error>

namespace fieldline::fusion {
namespace {

constexpr double kMaxNodes = 20e6;
// Bump when the file layout or the meaning of a node changes: old files then miss the key.
constexpr std::uint64_t kFormatVersion = 1;
constexpr char kMagic[8] = {'F', 'L', 'G', 'R', 'I', 'D', '0', '1'};
constexpr std::uint32_t kByteOrderMark = 0x01020304u;

class Fnv1a {
 public:
  void add(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < size; ++k) {
      hash_ ^= bytes[k];
      hash_ *= 0x100000001b3ull;
    }
  }
  void add(double value) {
    // +0 and -0 are the same setting.
    if (value == 0.0) value = 0.0;
    add(&value, sizeof value);
  }
  std::uint64_t value() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ull;
};

struct Geometry {
  double cell;
  double origin_x;
  double origin_y;
  int cols;
  int rows;
};

// The lines' centres lie within the goal lines and the touch lines.
Geometry geometryFor(const field::FieldModel& field, const LineGridSettings& settings) {
  validate(settings);
  const double half_x = field.length() / 2.0 + settings.margin_m;
  const double half_y = field.width() / 2.0 + settings.margin_m;
  const double cols = std::ceil(2.0 * half_x / settings.cell_m) + 1.0;
  const double rows = std::ceil(2.0 * half_y / settings.cell_m) + 1.0;
  if (cols * rows > kMaxNodes) {
    throw std::invalid_argument("line grid: too many nodes; use a larger cell size");
  }
  return Geometry{settings.cell_m, -half_x, -half_y, std::max(2, static_cast<int>(cols)),
                  std::max(2, static_cast<int>(rows))};
}

template <typename T>
void append(std::vector<char>& out, const T& value) {
  const char* bytes = reinterpret_cast<const char*>(&value);
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

// Reads a T at `offset` if the buffer holds it.
template <typename T>
bool take(const std::vector<char>& in, std::size_t& offset, T& value) {
  if (in.size() < offset + sizeof(T)) return false;
  std::memcpy(&value, in.data() + offset, sizeof(T));
  offset += sizeof(T);
  return true;
}

std::optional<LineGrid> fail(std::string* problem, std::string text) {
  if (problem) *problem = std::move(text);
  return std::nullopt;
}

}  // namespace

void validate(const LineGridSettings& s) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(s.cell_m)) throw std::invalid_argument("line grid: cell size must be positive");
  if (!(std::isfinite(s.margin_m) && s.margin_m >= 0.0)) {
    throw std::invalid_argument("line grid: margin must not be negative");
  }
  if (!positive(s.force_decay_per_m) || !positive(s.force_cap_m)) {
    throw std::invalid_argument("line grid: force decay and cap must be positive");
  }
}

void LineGrid::setGeometry(double cell, double origin_x, double origin_y, int cols, int rows) {
  cell_ = cell;
  inv_cell_ = 1.0 / cell;
  origin_x_ = origin_x;
  origin_y_ = origin_y;
  cols_ = cols;
  rows_ = rows;
  max_u_ = cols - 1;
  max_v_ = rows - 1;
}

void LineGrid::indexDistances() {
  distances_.resize(nodes_.size());
  std::transform(nodes_.begin(), nodes_.end(), distances_.begin(),
                 [](const Node& n) { return n.distance; });
}

LineGrid LineGrid::build(const field::FieldModel& field, const LineGridSettings& settings) {
  const Geometry g = geometryFor(field, settings);
  LineGrid grid;
  grid.key_ = lineGridKey(field, settings);
  grid.setGeometry(g.cell, g.origin_x, g.origin_y, g.cols, g.rows);
  grid.nodes_.resize(static_cast<std::size_t>(g.cols) * g.rows);

  const auto& segments = field.segments();
  const auto& arcs = field.arcs();
  std::vector<field::Vec2> pulls(segments.size() + arcs.size());
  std::vector<double> lengths(pulls.size());
  for (int j = 0; j < g.rows; ++j) {
    for (int i = 0; i < g.cols; ++i) {
      const field::Vec2 p(g.origin_x + i * g.cell, g.origin_y + j * g.cell);
      std::size_t k = 0;
      for (const auto& s : segments)
        pulls[k++] = field::closestPointOnSegment(s, p) - p;  // v_k, eq. 4.82
      for (const auto& a : arcs)
        pulls[k++] = field::closestPointOnArc(a, p) - p;
      double nearest = std::numeric_limits<double>::infinity();
      for (k = 0; k < pulls.size(); ++k) {
        lengths[k] = pulls[k].norm();
        nearest = std::min(nearest, lengths[k]);
      }
      // Eq. 4.81-4.84: weights exp(-eta |v_k|) normalised to sum one (shifted by the nearest
      // distance for range; the shift cancels), each pull capped at f_max.
      double weight_sum = 0.0;
      field::Vec2 force = field::Vec2::Zero();
      for (k = 0; k < pulls.size(); ++k) {
        const double w = std::exp(-settings.force_decay_per_m * (lengths[k] - nearest));
        weight_sum += w;
        if (lengths[k] > 0.0) {
          force += w * pulls[k] * (std::min(lengths[k], settings.force_cap_m) / lengths[k]);
        }
      }
      force /= weight_sum;
      grid.nodes_[static_cast<std::size_t>(j) * g.cols + i] =
          Node{static_cast<float>(nearest), static_cast<float>(force.x()),
               static_cast<float>(force.y())};
    }
  }
  grid.indexDistances();
  return grid;
}

std::uint64_t lineGridKey(const field::FieldModel& field, const LineGridSettings& settings) {
  Fnv1a h;
  h.add(&kFormatVersion, sizeof kFormatVersion);
  h.add(field.length());
  h.add(field.width());
  for (const auto& s : field.segments()) {
    for (double v : {s.a.x(), s.a.y(), s.b.x(), s.b.y()})
      h.add(v);
  }
  for (const auto& a : field.arcs()) {
    for (double v : {a.centre.x(), a.centre.y(), a.radius, a.start_angle, a.sweep})
      h.add(v);
  }
  for (double v :
       {settings.cell_m, settings.margin_m, settings.force_decay_per_m, settings.force_cap_m})
    h.add(v);
  return h.value();
}

std::string lineGridFileName(std::uint64_t key) {
  char name[64];
  std::snprintf(name, sizeof name, "line_grid_%016llx.bin", static_cast<unsigned long long>(key));
  return name;
}

void saveLineGrid(const LineGrid& grid, const std::string& path) {
  std::vector<char> bytes(std::begin(kMagic), std::end(kMagic));
  append(bytes, kByteOrderMark);
  append(bytes, grid.key());
  append(bytes, grid.cellSize());
  append(bytes, grid.originX());
  append(bytes, grid.originY());
  append(bytes, static_cast<std::int32_t>(grid.columns()));
  append(bytes, static_cast<std::int32_t>(grid.rows()));
  append(bytes, static_cast<std::uint64_t>(grid.nodes().size()));
  const char* node_bytes = reinterpret_cast<const char*>(grid.nodes().data());
  bytes.insert(bytes.end(), node_bytes, node_bytes + grid.nodes().size() * sizeof(LineGrid::Node));
  Fnv1a checksum;
  checksum.add(bytes.data(), bytes.size());
  append(bytes, checksum.value());

  // A name of its own per process, renamed over the target in one step.
  const std::string temporary = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      throw std::runtime_error("line grid: cannot write " + temporary);
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    throw std::runtime_error("line grid: cannot rename " + temporary + " to " + path);
  }
}

std::optional<LineGrid> loadLineGrid(const std::string& path, std::uint64_t expected_key,
                                     std::string* problem) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(problem, "missing");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  // The largest valid file: header, 20 million nodes, checksum.
  if (size < 0 || static_cast<double>(size) > kMaxNodes * sizeof(LineGrid::Node) + 1024.0) {
    return fail(problem, "unreadable or too large");
  }
  in.seekg(0);
  std::vector<char> bytes(static_cast<std::size_t>(size));
  in.read(bytes.data(), size);
  if (!in) return fail(problem, "read error");

  std::size_t offset = sizeof kMagic;
  if (bytes.size() < offset || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
    return fail(problem, "not a line grid file");
  }
  std::uint32_t mark = 0;
  std::uint64_t key = 0, count = 0;
  double cell = 0, origin_x = 0, origin_y = 0;
  std::int32_t cols = 0, rows = 0;
  if (!take(bytes, offset, mark) || !take(bytes, offset, key) || !take(bytes, offset, cell) ||
      !take(bytes, offset, origin_x) || !take(bytes, offset, origin_y) ||
      !take(bytes, offset, cols) || !take(bytes, offset, rows) || !take(bytes, offset, count)) {
    return fail(problem, "truncated header");
  }
  if (mark != kByteOrderMark) return fail(problem, "other byte order");
  if (key != expected_key) return fail(problem, "built for another field or grid settings");
  if (!(std::isfinite(cell) && cell > 0.0 && std::isfinite(origin_x) && std::isfinite(origin_y)) ||
      cols < 2 || rows < 2 || static_cast<double>(cols) * rows > kMaxNodes ||
      count != static_cast<std::uint64_t>(cols) * static_cast<std::uint64_t>(rows)) {
    return fail(problem, "inconsistent header");
  }
  const std::size_t node_bytes = count * sizeof(LineGrid::Node);
  if (bytes.size() != offset + node_bytes + sizeof(std::uint64_t)) {
    return fail(problem, "truncated or oversized");
  }
  Fnv1a checksum;
  checksum.add(bytes.data(), offset + node_bytes);
  std::size_t checksum_offset = offset + node_bytes;
  std::uint64_t stored = 0;
  take(bytes, checksum_offset, stored);
  if (stored != checksum.value()) return fail(problem, "checksum mismatch");

  LineGrid grid;
  grid.key_ = key;
  grid.setGeometry(cell, origin_x, origin_y, cols, rows);
  grid.nodes_.resize(count);
  std::memcpy(grid.nodes_.data(), bytes.data() + offset, node_bytes);
  for (const LineGrid::Node& n : grid.nodes_) {
    if (!(std::isfinite(n.distance) && n.distance >= 0.0f && std::isfinite(n.force_x) &&
          std::isfinite(n.force_y))) {
      return fail(problem, "non-finite or negative node");
    }
  }
  grid.indexDistances();
  return grid;
}

LineGrid loadOrBuildLineGrid(const field::FieldModel& field, const LineGridSettings& settings,
                             const std::string& cache_dir, GridSource* source,
                             std::string* problem) {
  const Geometry expected = geometryFor(field, settings);
  const std::uint64_t key = lineGridKey(field, settings);
  GridSource how = GridSource::kBuilt;
  std::string why;
  std::string path;
  if (!cache_dir.empty()) {
    path = (std::filesystem::path(cache_dir) / lineGridFileName(key)).string();
    std::optional<LineGrid> cached = loadLineGrid(path, key, &why);
    if (cached && cached->columns() == expected.cols && cached->rows() == expected.rows &&
        cached->cellSize() == expected.cell && cached->originX() == expected.origin_x &&
        cached->originY() == expected.origin_y) {
      if (source) *source = GridSource::kLoadedFromCache;
      if (problem) problem->clear();
      return std::move(*cached);
    }
    if (cached) why = "geometry differs from the settings";
    if (why != "missing") how = GridSource::kRebuiltBadCache;
  }
  LineGrid grid = LineGrid::build(field, settings);
  if (!path.empty()) {
    try {
      std::error_code ignored;
      std::filesystem::create_directories(cache_dir, ignored);
      saveLineGrid(grid, path);
    } catch (const std::exception& e) {
      why += why.empty() ? e.what() : std::string("; ") + e.what();
    }
  }
  if (source) *source = how;
  if (problem) *problem = why;
  return grid;
}

}  // namespace fieldline::fusion
