// The simulated camera's floor raster (carpet texture, lines and light baked in, field frame) as
// the floor pass reads it, and its file on disk. Building it for an msl field at 1 cm is most of
// a camera's start-up (about 0.8 s of CPU); a restarted camera should be back at full rate within
// a second, so the raster is cached like fusion's distance grid.
//
// The file is the raster's image: a header with the key, the exact description of everything the
// raster depends on (format version, the field's carpet, lines, arcs and penalty marks, and the
// render parameters the floor uses: resolution, colours, texture, lighting, noise seed), the
// levels' tiles at 64-byte aligned offsets and a checksum. A camera maps the file read-only and
// shared and the floor pass reads the mapped tiles, so the six cameras of a simulated team read
// one copy (the same page-cache pages) instead of six in the shared caches. The name carries a
// hash of the key. The mirror model is not part of it: the raster is in the field frame.
//
// A file is written under a name of its own and renamed over the target in one step, so cameras
// that start together never read half a file, and a mapping never sees a file shrink (rename
// replaces the name; the mapped inode stays as it was). A missing, truncated, corrupt (checksum)
// or mismatched file is never trusted: the raster is rebuilt and the file rewritten, and the
// caller is told why (the camera logs it). Without a cache directory the image stays in memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/frame.hpp"
#include "common/field/field_model.hpp"

namespace fieldline::camera {

struct RenderParams;

// Bump when SimRenderer::buildFloorRaster changes what it computes from the same inputs, or the
// file's layout changes: files of another version are rebuilt. 2: tiled levels, 64-byte aligned.
inline constexpr std::uint32_t kFloorRasterVersion = 2;

// One mip level of the floor raster as built: cols x rows cells of `cell` metres, row-major, from
// the carpet's corner (-half_x, -half_y).
struct FloorRasterLevel {
  double cell = 0.0;
  double inv_cell = 0.0;
  int cols = 0;
  int rows = 0;
  std::vector<Yuv> cells;
};

// One level as the floor pass reads it: the same cells in 4x4 tiles of 4-byte cells (Y, U, V, 0
// in a little-endian word), tile_cols tiles a row, each tile one 64-byte aligned cache line holding
// its 16 cells row by row; cells beyond cols x rows are zero.
struct TiledLevel {
  double cell = 0.0;
  double inv_cell = 0.0;
  int cols = 0;
  int rows = 0;
  int tile_cols = 0;
  const std::uint32_t* tiles = nullptr;
};

// Where cell (i, j) lies in a level's tiles: tileRowOffset(tile_cols, j) + tileColumnOffset(i).
inline constexpr int kTileShift = 2;
inline constexpr int kTileMask = (1 << kTileShift) - 1;
[[gnu::always_inline]] inline std::size_t tileRowOffset(int tile_cols, int j) {
  return static_cast<std::size_t>(j >> kTileShift) * static_cast<std::size_t>(tile_cols) * 16 +
         static_cast<std::size_t>((j & kTileMask) << kTileShift);
}
[[gnu::always_inline]] inline std::size_t tileColumnOffset(int i) {
  return static_cast<std::size_t>(i >> kTileShift) * 16 + static_cast<std::size_t>(i & kTileMask);
}
inline Yuv tiledCell(const TiledLevel& l, int i, int j) {
  const std::uint32_t c = l.tiles[tileRowOffset(l.tile_cols, j) + tileColumnOffset(i)];
  return Yuv{static_cast<std::uint8_t>(c), static_cast<std::uint8_t>(c >> 8),
             static_cast<std::uint8_t>(c >> 16)};
}

// A file mapped read-only and shared (MAP_SHARED: every process mapping it reads the same
// page-cache pages); unmapped on destruction. Only ever map files that are replaced by rename,
// never rewritten in place: a file truncated under a mapping makes reads beyond its new end fault.
class MappedFile {
 public:
  MappedFile() = default;
  // Maps `path`; an empty MappedFile with the reason in `problem` when it cannot.
  static MappedFile open(const std::string& path, std::string* problem = nullptr);
  MappedFile(MappedFile&& other) noexcept;
  MappedFile& operator=(MappedFile&& other) noexcept;
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  ~MappedFile();

  const std::uint8_t* data() const { return data_; }
  std::size_t size() const { return size_; }

 private:
  const std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
};

// The floor raster's levels (finest first, each half the one before) in tiles, held either as a
// read-only shared mapping of its cache file or, built here, in memory with the same bytes.
class FloorRaster {
 public:
  FloorRaster() = default;
  // Tiles `levels` into the file's image in memory, with `key`. Throws std::invalid_argument when
  // the levels are inconsistent.
  static FloorRaster build(const std::vector<std::uint8_t>& key,
                           const std::vector<FloorRasterLevel>& levels);
  // Maps a file written by save() and checks it (checksum, key, layout) before anything uses
  // it; nullopt with the reason in `problem` ("missing", "checksum mismatch", "built for other
  // inputs", ...) when it cannot be trusted.
  static std::optional<FloorRaster> map(const std::string& path,
                                        const std::vector<std::uint8_t>& key,
                                        std::string* problem = nullptr);
  // Writes the image to `path` atomically (a temporary file of its own, then rename). Throws
  // std::runtime_error on I/O errors.
  void save(const std::string& path) const;

  const std::vector<TiledLevel>& levels() const { return levels_; }
  bool mapped() const { return mapping_.data() != nullptr; }
  // The image: exactly the file's bytes.
  const std::uint8_t* data() const { return image_; }
  std::size_t size() const { return size_; }

 private:
  struct Free {
    void operator()(std::uint8_t* p) const { std::free(p); }
  };
  // Checks image_ (size_ bytes) against `key` and points levels_ at its tiles.
  bool parse(const std::vector<std::uint8_t>& key, std::string* problem);

  MappedFile mapping_;
  std::unique_ptr<std::uint8_t, Free> memory_;
  const std::uint8_t* image_ = nullptr;
  std::size_t size_ = 0;
  std::vector<TiledLevel> levels_;
};

// The exact bytes of everything the raster depends on.
std::vector<std::uint8_t> floorRasterKey(const field::FieldModel& field,
                                         const RenderParams& params);
// "floor_raster_<16 hex digits of the key's hash>.bin".
std::string floorRasterFileName(const std::vector<std::uint8_t>& key);

// How the renderer came by its raster (SimRenderer::rasterMapped says whether it reads a mapping
// of the cache file or a copy in its own memory).
enum class RasterSource { kBuilt, kLoadedFromCache, kRebuiltBadCache };

}  // namespace fieldline::camera
