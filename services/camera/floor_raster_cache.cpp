#include "services/camera/floor_raster_cache.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "services/camera/sim_renderer.hpp"

namespace fieldline::camera {
namespace {

constexpr char kMagic[8] = {'F', 'L', 'R', 'A', 'S', 'T', 'E', 'R'};
constexpr std::uint32_t kByteOrderMark = 0x01020304u;
constexpr std::size_t kMaxKeyBytes = 1 << 20;
constexpr int kMaxLevels = 32;
constexpr double kMaxCells = 200e6;  // 20 x 100 m at 1 cm is 20 million

std::uint64_t fnv1a(const std::uint8_t* data, std::size_t size) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (std::size_t k = 0; k < size; ++k) {
    h ^= data[k];
    h *= 0x100000001b3ull;
  }
  return h;
}

template <typename T>
void append(std::vector<std::uint8_t>& bytes, T value) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
  bytes.insert(bytes.end(), p, p + sizeof value);
}

void appendDouble(std::vector<std::uint8_t>& bytes, double value) {
  if (value == 0.0) value = 0.0;  // +0 and -0 are the same input
  append(bytes, value);
}

void appendVec(std::vector<std::uint8_t>& bytes, const Vec2& v) {
  appendDouble(bytes, v.x());
  appendDouble(bytes, v.y());
}

void appendBgr(std::vector<std::uint8_t>& bytes, Bgr c) {
  bytes.push_back(c.b);
  bytes.push_back(c.g);
  bytes.push_back(c.r);
}

template <typename T>
bool take(const std::vector<std::uint8_t>& bytes, std::size_t& offset, T& value) {
  if (offset > bytes.size() || bytes.size() - offset < sizeof value) return false;
  std::memcpy(&value, bytes.data() + offset, sizeof value);
  offset += sizeof value;
  return true;
}

std::nullopt_t fail(std::string* problem, const std::string& why) {
  if (problem) *problem = why;
  return std::nullopt;
}

}  // namespace

std::vector<std::uint8_t> floorRasterKey(const field::FieldModel& field,
                                         const RenderParams& params) {
  std::vector<std::uint8_t> key;
  append(key, kFloorRasterVersion);
  appendVec(key, field.carpetHalfExtent());
  append(key, static_cast<std::uint32_t>(field.segments().size()));
  for (const field::LineSegment& s : field.segments()) {
    appendVec(key, s.a);
    appendVec(key, s.b);
    appendDouble(key, s.width);
  }
  append(key, static_cast<std::uint32_t>(field.arcs().size()));
  for (const field::LineArc& a : field.arcs()) {
    appendVec(key, a.centre);
    for (double v : {a.radius, a.start_angle, a.sweep, a.width})
      appendDouble(key, v);
  }
  append(key, static_cast<std::uint32_t>(field.penaltyMarks().size()));
  for (const Vec2& m : field.penaltyMarks())
    appendVec(key, m);
  appendDouble(key, field.dimensions().penalty_mark_diameter);

  appendDouble(key, params.floor_resolution);
  appendBgr(key, params.carpet);
  appendBgr(key, params.line);
  for (double t : params.carpet_texture)
    appendDouble(key, t);
  appendDouble(key, params.lighting.ambient);
  append(key, static_cast<std::uint32_t>(params.lighting.spots.size()));
  for (const LightSpot& spot : params.lighting.spots) {
    appendVec(key, spot.position);
    appendDouble(key, spot.radius);
    appendDouble(key, spot.gain);
  }
  appendVec(key, params.lighting.windows.direction);
  appendDouble(key, params.lighting.windows.gain);
  appendDouble(key, params.lighting.windows.falloff);
  append(key, params.noise_seed);
  return key;
}

std::string floorRasterFileName(const std::vector<std::uint8_t>& key) {
  char name[64];
  std::snprintf(name, sizeof name, "floor_raster_%016llx.bin",
                static_cast<unsigned long long>(fnv1a(key.data(), key.size())));
  return name;
}

void saveFloorRaster(const std::string& path, const std::vector<std::uint8_t>& key,
                     const std::vector<FloorRasterLevel>& levels) {
  std::size_t total = 0;
  for (const FloorRasterLevel& l : levels)
    total += 3 * l.cells.size();
  std::vector<std::uint8_t> bytes(std::begin(kMagic), std::end(kMagic));
  bytes.reserve(total + key.size() + 64 * levels.size() + 64);
  append(bytes, kByteOrderMark);
  append(bytes, static_cast<std::uint64_t>(key.size()));
  bytes.insert(bytes.end(), key.begin(), key.end());
  append(bytes, static_cast<std::int32_t>(levels.size()));
  for (const FloorRasterLevel& l : levels) {
    append(bytes, l.cell);
    append(bytes, static_cast<std::int32_t>(l.cols));
    append(bytes, static_cast<std::int32_t>(l.rows));
    if (l.cells.size() != static_cast<std::size_t>(l.cols) * static_cast<std::size_t>(l.rows)) {
      throw std::runtime_error("floor raster: a level's cells disagree with its size");
    }
    for (const Yuv& c : l.cells) {
      bytes.push_back(c.y);
      bytes.push_back(c.u);
      bytes.push_back(c.v);
    }
  }
  append(bytes, fnv1a(bytes.data(), bytes.size()));

  const std::string temporary = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      throw std::runtime_error("floor raster: cannot write " + temporary);
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    throw std::runtime_error("floor raster: cannot rename " + temporary + " to " + path);
  }
}

std::optional<std::vector<FloorRasterLevel>> loadFloorRaster(const std::string& path,
                                                             const std::vector<std::uint8_t>& key,
                                                             std::string* problem) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(problem, "missing");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0 || static_cast<double>(size) > kMaxCells * 3.0 * 1.5 + kMaxKeyBytes) {
    return fail(problem, "unreadable or too large");
  }
  in.seekg(0);
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), size);
  if (!in) return fail(problem, "read error");

  if (bytes.size() < sizeof kMagic + sizeof(std::uint64_t) ||
      std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
    return fail(problem, "not a floor raster file");
  }
  // The checksum first: nothing of a damaged file is interpreted.
  const std::size_t body = bytes.size() - sizeof(std::uint64_t);
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + body, sizeof stored);
  if (stored != fnv1a(bytes.data(), body)) return fail(problem, "checksum mismatch");
  bytes.resize(body);

  std::size_t offset = sizeof kMagic;
  std::uint32_t mark = 0;
  std::uint64_t key_size = 0;
  if (!take(bytes, offset, mark) || !take(bytes, offset, key_size)) {
    return fail(problem, "truncated header");
  }
  if (mark != kByteOrderMark) return fail(problem, "other byte order");
  if (key_size > kMaxKeyBytes || key_size > bytes.size() - offset) {
    return fail(problem, "truncated key");
  }
  if (key_size != key.size() || std::memcmp(bytes.data() + offset, key.data(), key.size()) != 0) {
    return fail(problem, "built for other inputs (field, render parameters or version)");
  }
  offset += key_size;
  std::int32_t count = 0;
  if (!take(bytes, offset, count) || count < 1 || count > kMaxLevels) {
    return fail(problem, "bad level count");
  }
  std::vector<FloorRasterLevel> levels(static_cast<std::size_t>(count));
  for (FloorRasterLevel& l : levels) {
    std::int32_t cols = 0, rows = 0;
    if (!take(bytes, offset, l.cell) || !take(bytes, offset, cols) || !take(bytes, offset, rows)) {
      return fail(problem, "truncated level header");
    }
    if (!(std::isfinite(l.cell) && l.cell > 0.0) || cols < 1 || rows < 1 ||
        static_cast<double>(cols) * rows > kMaxCells) {
      return fail(problem, "inconsistent level header");
    }
    const std::size_t n = static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
    if (bytes.size() - offset < 3 * n) return fail(problem, "truncated cells");
    l.cols = cols;
    l.rows = rows;
    l.inv_cell = 1.0 / l.cell;
    l.cells.resize(n);
    const std::uint8_t* p = bytes.data() + offset;
    for (std::size_t k = 0; k < n; ++k, p += 3)
      l.cells[k] = Yuv{p[0], p[1], p[2]};
    offset += 3 * n;
  }
  if (offset != bytes.size()) return fail(problem, "trailing bytes");
  // Each level halves the one before.
  for (std::size_t k = 1; k < levels.size(); ++k) {
    const FloorRasterLevel& fine = levels[k - 1];
    const FloorRasterLevel& coarse = levels[k];
    if (coarse.cell != 2.0 * fine.cell || coarse.cols != (fine.cols + 1) / 2 ||
        coarse.rows != (fine.rows + 1) / 2) {
      return fail(problem, "levels do not halve");
    }
  }
  return levels;
}

void SimRenderer::loadOrBuildFloorRaster(const field::FieldModel& field,
                                         const std::string& cache_dir) {
  raster_source_ = RasterSource::kBuilt;
  raster_problem_.clear();
  std::string path;
  std::vector<std::uint8_t> key;
  if (!cache_dir.empty()) {
    key = floorRasterKey(field, params_);
    path = (std::filesystem::path(cache_dir) / floorRasterFileName(key)).string();
    std::string why;
    std::optional<std::vector<FloorRasterLevel>> cached = loadFloorRaster(path, key, &why);
    const int cols = static_cast<int>(std::ceil(2.0 * carpet_half_.x() / params_.floor_resolution));
    const int rows = static_cast<int>(std::ceil(2.0 * carpet_half_.y() / params_.floor_resolution));
    if (cached && (cached->front().cols != cols || cached->front().rows != rows ||
                   cached->front().cell != params_.floor_resolution)) {
      cached.reset();
      why = "size differs from the field's carpet";
    }
    if (cached) {
      raster_ = std::move(*cached);
      raster_source_ = RasterSource::kLoadedFromCache;
      return;
    }
    if (why != "missing") {
      raster_source_ = RasterSource::kRebuiltBadCache;
      raster_problem_ = path + ": " + why;
    }
  }
  raster_.clear();
  buildFloorRaster(field);
  if (path.empty()) return;
  try {
    std::error_code ignored;
    std::filesystem::create_directories(cache_dir, ignored);
    saveFloorRaster(path, key, raster_);
  } catch (const std::exception& e) {
    // Not an error: the raster is right, only the next start will build it again.
    raster_problem_ += (raster_problem_.empty() ? "" : "; ") + std::string(e.what());
  }
}

}  // namespace fieldline::camera
