#include "services/camera/floor_raster_cache.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <new>
#include <stdexcept>
#include <utility>

#include "services/camera/sim_renderer.hpp"

namespace fieldline::camera {
namespace {

constexpr char kMagic[8] = {'F', 'L', 'R', 'A', 'S', 'T', 'E', 'R'};
constexpr std::uint32_t kByteOrderMark = 0x01020304u;
constexpr std::size_t kMaxKeyBytes = 1 << 20;
constexpr int kMaxLevels = 32;
constexpr double kMaxCells = 200e6;  // 20 x 100 m at 1 cm is 20 million
constexpr double kMaxFileBytes = kMaxCells * 4.0 * 1.5 + kMaxKeyBytes;

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
bool take(const std::uint8_t* bytes, std::size_t size, std::size_t& offset, T& value) {
  if (offset > size || size - offset < sizeof value) return false;
  std::memcpy(&value, bytes + offset, sizeof value);
  offset += sizeof value;
  return true;
}

bool fail(std::string* problem, const std::string& why) {
  if (problem) *problem = why;
  return false;
}

// The tiles start at a multiple of 64 bytes from the image's start (a page-aligned mapping or a
// 64-byte aligned allocation), and every level's tiles are whole cache lines: each tile is one.
constexpr std::size_t kLine = 64;
std::size_t wholeLines(std::size_t bytes) {
  return (bytes + kLine - 1) / kLine * kLine;
}
int tileCount(int cells) {
  return (cells + kTileMask) >> kTileShift;
}
std::size_t levelBytes(int cols, int rows) {
  return static_cast<std::size_t>(tileCount(cols)) * static_cast<std::size_t>(tileCount(rows)) *
         kLine;
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

// --- MappedFile ---

MappedFile MappedFile::open(const std::string& path, std::string* problem) {
  MappedFile file;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    fail(problem, errno == ENOENT || errno == ENOTDIR
                      ? "missing"
                      : "cannot open: " + std::string(std::strerror(errno)));
    return file;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || st.st_size <= 0 || static_cast<double>(st.st_size) > kMaxFileBytes) {
    fail(problem, "empty, unreadable or too large");
  } else {
    const auto size = static_cast<std::size_t>(st.st_size);
    void* p = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) {
      fail(problem, "cannot map: " + std::string(std::strerror(errno)));
    } else {
      file.data_ = static_cast<const std::uint8_t*>(p);
      file.size_ = size;
    }
  }
  ::close(fd);  // the mapping keeps the file
  return file;
}

MappedFile::MappedFile(MappedFile&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}

MappedFile& MappedFile::operator=(MappedFile&& other) noexcept {
  if (this != &other) {
    MappedFile old(std::move(*this));
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

MappedFile::~MappedFile() {
  if (data_) ::munmap(const_cast<std::uint8_t*>(data_), size_);
}

// --- FloorRaster ---
//
// The image: magic, byte-order mark, key size (u64) and key, level count (i32), per level its cell
// (f64), cols and rows (i32); zeros up to a whole number of cache lines; each level's tiles
// (levelBytes); the FNV-1a checksum (u64) of everything before it.

FloorRaster FloorRaster::build(const std::vector<std::uint8_t>& key,
                               const std::vector<FloorRasterLevel>& levels) {
  std::vector<std::uint8_t> header(std::begin(kMagic), std::end(kMagic));
  append(header, kByteOrderMark);
  append(header, static_cast<std::uint64_t>(key.size()));
  header.insert(header.end(), key.begin(), key.end());
  append(header, static_cast<std::int32_t>(levels.size()));
  std::size_t size = 0;
  for (const FloorRasterLevel& l : levels) {
    if (l.cols < 1 || l.rows < 1 ||
        l.cells.size() != static_cast<std::size_t>(l.cols) * static_cast<std::size_t>(l.rows)) {
      throw std::invalid_argument("floor raster: a level's cells disagree with its size");
    }
    append(header, l.cell);
    append(header, static_cast<std::int32_t>(l.cols));
    append(header, static_cast<std::int32_t>(l.rows));
    size += levelBytes(l.cols, l.rows);
  }
  const std::size_t tiles_at = wholeLines(header.size());
  size += tiles_at + sizeof(std::uint64_t);

  FloorRaster raster;
  raster.memory_.reset(static_cast<std::uint8_t*>(std::aligned_alloc(kLine, wholeLines(size))));
  if (!raster.memory_) throw std::bad_alloc();
  std::uint8_t* const image = raster.memory_.get();
  std::memset(image, 0, wholeLines(size));
  std::memcpy(image, header.data(), header.size());
  std::size_t at = tiles_at;
  for (const FloorRasterLevel& l : levels) {
    auto* const tiles = reinterpret_cast<std::uint32_t*>(image + at);
    const int tile_cols = tileCount(l.cols);
    for (int j = 0; j < l.rows; ++j) {
      for (int i = 0; i < l.cols; ++i) {
        const Yuv& c = l.cells[static_cast<std::size_t>(j) * l.cols + i];
        tiles[tileRowOffset(tile_cols, j) + tileColumnOffset(i)] =
            c.y | static_cast<std::uint32_t>(c.u) << 8 | static_cast<std::uint32_t>(c.v) << 16;
      }
    }
    raster.levels_.push_back({l.cell, 1.0 / l.cell, l.cols, l.rows, tile_cols, tiles});
    at += levelBytes(l.cols, l.rows);
  }
  const std::uint64_t checksum = fnv1a(image, at);
  std::memcpy(image + at, &checksum, sizeof checksum);
  raster.image_ = image;
  raster.size_ = size;
  return raster;
}

void FloorRaster::save(const std::string& path) const {
  const std::string temporary = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(image_), static_cast<std::streamsize>(size_));
    out.close();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      throw std::runtime_error("floor raster: cannot write " + temporary);
    }
  }
  // Only complete files ever carry the name, and a file under it is never changed in place: a
  // camera mapping the old one keeps reading it whole (the mapping holds the old inode).
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    throw std::runtime_error("floor raster: cannot rename " + temporary + " to " + path);
  }
}

std::optional<FloorRaster> FloorRaster::map(const std::string& path,
                                            const std::vector<std::uint8_t>& key,
                                            std::string* problem) {
  FloorRaster raster;
  raster.mapping_ = MappedFile::open(path, problem);
  if (!raster.mapping_.data()) return std::nullopt;
  raster.image_ = raster.mapping_.data();
  raster.size_ = raster.mapping_.size();
  if (!raster.parse(key, problem)) return std::nullopt;
  return raster;
}

bool FloorRaster::parse(const std::vector<std::uint8_t>& key, std::string* problem) {
  const std::uint8_t* const bytes = image_;
  if (size_ < sizeof kMagic + sizeof(std::uint64_t) ||
      std::memcmp(bytes, kMagic, sizeof kMagic) != 0) {
    return fail(problem, "not a floor raster file");
  }
  // The checksum first: nothing of a damaged file is interpreted.
  const std::size_t body = size_ - sizeof(std::uint64_t);
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes + body, sizeof stored);
  if (stored != fnv1a(bytes, body)) return fail(problem, "checksum mismatch");

  std::size_t offset = sizeof kMagic;
  std::uint32_t mark = 0;
  std::uint64_t key_size = 0;
  if (!take(bytes, body, offset, mark) || !take(bytes, body, offset, key_size)) {
    return fail(problem, "truncated header");
  }
  if (mark != kByteOrderMark) return fail(problem, "other byte order");
  if (key_size > kMaxKeyBytes || key_size > body - offset) return fail(problem, "truncated key");
  if (key_size != key.size() || std::memcmp(bytes + offset, key.data(), key.size()) != 0) {
    return fail(problem, "built for other inputs (field, render parameters or version)");
  }
  offset += key_size;
  std::int32_t count = 0;
  if (!take(bytes, body, offset, count) || count < 1 || count > kMaxLevels) {
    return fail(problem, "bad level count");
  }
  std::vector<TiledLevel> levels(static_cast<std::size_t>(count));
  double tile_bytes = 0.0;
  for (TiledLevel& l : levels) {
    std::int32_t cols = 0, rows = 0;
    if (!take(bytes, body, offset, l.cell) || !take(bytes, body, offset, cols) ||
        !take(bytes, body, offset, rows)) {
      return fail(problem, "truncated level header");
    }
    if (!(std::isfinite(l.cell) && l.cell > 0.0) || cols < 1 || rows < 1 ||
        static_cast<double>(cols) * rows > kMaxCells) {
      return fail(problem, "inconsistent level header");
    }
    l.inv_cell = 1.0 / l.cell;
    l.cols = cols;
    l.rows = rows;
    l.tile_cols = tileCount(cols);
    tile_bytes += static_cast<double>(levelBytes(cols, rows));
  }
  std::size_t at = wholeLines(offset);
  if (static_cast<double>(at) + tile_bytes > static_cast<double>(body)) {
    return fail(problem, "truncated cells");
  }
  if (reinterpret_cast<std::uintptr_t>(bytes) % kLine != 0) {
    return fail(problem, "image not aligned to a cache line");
  }
  for (TiledLevel& l : levels) {
    l.tiles = reinterpret_cast<const std::uint32_t*>(bytes + at);
    at += levelBytes(l.cols, l.rows);
  }
  if (at != body) return fail(problem, "trailing bytes");
  // Each level halves the one before.
  for (std::size_t k = 1; k < levels.size(); ++k) {
    const TiledLevel& fine = levels[k - 1];
    const TiledLevel& coarse = levels[k];
    if (coarse.cell != 2.0 * fine.cell || coarse.cols != (fine.cols + 1) / 2 ||
        coarse.rows != (fine.rows + 1) / 2) {
      return fail(problem, "levels do not halve");
    }
  }
  levels_ = std::move(levels);
  return true;
}

// --- the renderer's raster ---

void SimRenderer::loadOrBuildFloorRaster(const field::FieldModel& field,
                                         const std::string& cache_dir) {
  raster_source_ = RasterSource::kBuilt;
  raster_problem_.clear();
  raster_path_.clear();
  const std::vector<std::uint8_t> key = floorRasterKey(field, params_);
  if (cache_dir.empty()) {
    raster_ = FloorRaster::build(key, buildFloorRaster(field));
    return;
  }
  const std::string path = (std::filesystem::path(cache_dir) / floorRasterFileName(key)).string();
  const int cols = static_cast<int>(std::ceil(2.0 * carpet_half_.x() / params_.floor_resolution));
  const int rows = static_cast<int>(std::ceil(2.0 * carpet_half_.y() / params_.floor_resolution));
  // A mapped file for exactly these inputs (checked before use), of the carpet's size.
  const auto mapFile = [&](std::string& why) {
    std::optional<FloorRaster> mapped = FloorRaster::map(path, key, &why);
    if (mapped && (mapped->levels().front().cols != cols || mapped->levels().front().rows != rows ||
                   mapped->levels().front().cell != params_.floor_resolution)) {
      mapped.reset();
      why = "size differs from the field's carpet";
    }
    return mapped;
  };
  std::string why;
  if (std::optional<FloorRaster> cached = mapFile(why)) {
    raster_ = std::move(*cached);
    raster_source_ = RasterSource::kLoadedFromCache;
    raster_path_ = path;
    return;
  }
  if (why != "missing") {
    raster_source_ = RasterSource::kRebuiltBadCache;
    raster_problem_ = path + ": " + why;
  }
  raster_ = FloorRaster::build(key, buildFloorRaster(field));
  try {
    std::error_code ignored;
    std::filesystem::create_directories(cache_dir, ignored);
    raster_.save(path);
  } catch (const std::exception& e) {
    // Not an error: the raster is right, only the next start will build it again.
    raster_problem_ += (raster_problem_.empty() ? "" : "; ") + std::string(e.what());
    return;
  }
  // The file just written (or one another camera renamed over it since: the same inputs give the
  // same bytes) instead of this copy, so that this camera shares it too.
  if (std::optional<FloorRaster> written = mapFile(why)) {
    raster_ = std::move(*written);
    raster_path_ = path;
  } else {
    raster_problem_ +=
        (raster_problem_.empty() ? "" : "; ") + path + " written but not mapped: " + why;
  }
}

}  // namespace fieldline::camera
