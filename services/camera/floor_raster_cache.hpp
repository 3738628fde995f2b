// The simulated camera's floor raster (carpet texture, lines and light baked in, field frame) on
// disk. Building it for an msl field at 1 cm is most of a camera's start-up (about 0.8 s of CPU);
// a restarted camera should be back at full rate within a second, so the raster is cached like
// fusion's distance grid.
//
// The file holds the key, the exact description of everything the raster depends on (format
// version, the field's carpet, lines, arcs and penalty marks, and the render parameters the floor
// uses: resolution, colours, texture, lighting, noise seed), so a file is used only for exactly
// these inputs; the name carries a hash of the key. The mirror model is not part of it: the
// raster is in the field frame and does not depend on it. A file is written under a name of its
// own and renamed over the target in one step, so cameras that start together never read half a
// file. A missing, truncated, corrupt (checksum) or mismatched file is never trusted: the raster
// is rebuilt and the file rewritten, and the caller is told why (the camera logs it).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/frame.hpp"
#include "common/field/field_model.hpp"

namespace fieldline::camera {

struct RenderParams;

// Bump when SimRenderer::buildFloorRaster changes what it computes from the same inputs: files
// of another version are rebuilt.
inline constexpr std::uint32_t kFloorRasterVersion = 1;

// One mip level of the floor raster: cols x rows cells of `cell` metres, row-major, from the
// carpet's corner (-half_x, -half_y).
struct FloorRasterLevel {
  double cell = 0.0;
  double inv_cell = 0.0;
  int cols = 0;
  int rows = 0;
  std::vector<Yuv> cells;
};

// The exact bytes of everything the raster depends on.
std::vector<std::uint8_t> floorRasterKey(const field::FieldModel& field,
                                         const RenderParams& params);
// "floor_raster_<16 hex digits of the key's hash>.bin".
std::string floorRasterFileName(const std::vector<std::uint8_t>& key);

// Writes `levels` (finest first) with `key`; atomic (temporary file, rename). Throws
// std::runtime_error on I/O errors.
void saveFloorRaster(const std::string& path, const std::vector<std::uint8_t>& key,
                     const std::vector<FloorRasterLevel>& levels);
// Reads a file written by saveFloorRaster; nullopt with the reason in `problem` ("missing",
// "checksum mismatch", "built for other inputs", ...) when it cannot be trusted.
std::optional<std::vector<FloorRasterLevel>> loadFloorRaster(const std::string& path,
                                                             const std::vector<std::uint8_t>& key,
                                                             std::string* problem = nullptr);

// How the renderer came by its raster.
enum class RasterSource { kBuilt, kLoadedFromCache, kRebuiltBadCache };

}  // namespace fieldline::camera
