#include "services/camera/floor_raster_cache.hpp"

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/field/field_model.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/sim_renderer.hpp"

namespace fieldline::camera {
namespace floor_raster_cache_test {

namespace fs = std::filesystem;

// A coarser raster than the preset's keeps each build short; the cache does not care.
struct CacheSetup {
  CameraConfig config = loadCameraConfigPreset("omni_sim");
  field::FieldModel field = field::loadFieldPreset("msl");
  RenderParams params;
  fs::path dir;

  CacheSetup() {
    params = *config.render;
    params.floor_resolution = 0.02;
    dir = fs::temp_directory_path() /
          ("fieldline_raster_cache_test_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
  }
  ~CacheSetup() {
    std::error_code ignored;
    fs::remove_all(dir, ignored);
  }

  std::unique_ptr<SimRenderer> make(const RenderParams& p, const std::string& cache) const {
    return std::make_unique<SimRenderer>(config.model.mirror, field, p, cache);
  }
  fs::path file(const RenderParams& p) const {
    return dir / floorRasterFileName(floorRasterKey(field, p));
  }
};

std::vector<std::uint8_t> renderOne(SimRenderer& renderer,
                                    const geometry::Pose2& pose = {-1.3, 0.8, 0.4}) {
  SimScene scene;
  scene.robot = pose;
  scene.ball = SimBall{{0.5, 0.2}, 0.11};
  scene.robots.push_back({{1.5, -1.0}, 0.25, false});
  scene.frame_number = 7;
  std::vector<std::uint8_t> yuyv;
  renderer.render(scene, yuyv);
  return yuyv;
}

TEST(FloorRasterCache, SecondRendererReadsTheCacheAndRendersTheSameFrames) {
  CacheSetup s;
  const auto built = s.make(s.params, s.dir.string());
  EXPECT_EQ(built->rasterSource(), RasterSource::kBuilt);
  EXPECT_EQ(built->rasterProblem(), "");
  ASSERT_TRUE(fs::exists(s.file(s.params)));
  // No temporary file is left behind.
  EXPECT_EQ(std::distance(fs::directory_iterator(s.dir), fs::directory_iterator()), 1);
  // The one that built it reads the file it wrote, as every later one does.
  EXPECT_TRUE(built->rasterMapped());
  EXPECT_EQ(built->rasterPath(), s.file(s.params).string());

  const auto loaded = s.make(s.params, s.dir.string());
  EXPECT_EQ(loaded->rasterSource(), RasterSource::kLoadedFromCache);
  EXPECT_TRUE(loaded->rasterMapped());
  EXPECT_EQ(loaded->rasterPath(), s.file(s.params).string());
  const auto uncached = s.make(s.params, "");
  EXPECT_EQ(uncached->rasterSource(), RasterSource::kBuilt);
  EXPECT_FALSE(uncached->rasterMapped());
  EXPECT_EQ(uncached->rasterPath(), "");

  // The same bytes from the mapped file as from the raster in memory, here and at the carpet's
  // corners and edges (cells repeated at the raster's edge, floor beyond it).
  const Vec2 half = s.field.carpetHalfExtent();
  for (const geometry::Pose2& pose :
       {geometry::Pose2{-1.3, 0.8, 0.4}, geometry::Pose2{half.x() - 0.2, half.y() - 0.1, 2.0},
        geometry::Pose2{-half.x() + 0.05, -half.y() + 0.3, -0.7},
        geometry::Pose2{0.0, -half.y() + 0.01, 3.1}}) {
    const std::vector<std::uint8_t> a = renderOne(*uncached, pose);
    EXPECT_EQ(renderOne(*built, pose), a);
    EXPECT_EQ(renderOne(*loaded, pose), a);
  }
  for (const Vec2& p :
       {Vec2(0.0, 0.0), Vec2(-3.1, 1.7), Vec2(5.9, -3.9), Vec2(-half.x(), -half.y()),
        Vec2(half.x() - 1e-3, half.y() - 1e-3), Vec2(half.x() + 0.1, 0.0)}) {
    EXPECT_EQ(loaded->floorColour(p).y, uncached->floorColour(p).y);
    EXPECT_EQ(loaded->floorColour(p).u, uncached->floorColour(p).u);
    EXPECT_EQ(loaded->floorColour(p).v, uncached->floorColour(p).v);
  }
}

TEST(FloorRasterCache, AMappedRasterOutlivesItsFileBeingReplaced) {
  CacheSetup s;
  s.make(s.params, s.dir.string());
  const auto mapped = s.make(s.params, s.dir.string());
  ASSERT_TRUE(mapped->rasterMapped());
  const std::vector<std::uint8_t> before = renderOne(*mapped);
  // Another camera replaces the file (writers only ever rename a complete file over it) and the
  // file goes: the mapping still holds the old one, whole.
  fs::remove(s.file(s.params));
  const auto rebuilt = s.make(s.params, s.dir.string());
  EXPECT_EQ(rebuilt->rasterSource(), RasterSource::kBuilt);
  EXPECT_TRUE(rebuilt->rasterMapped());
  fs::remove(s.file(s.params));
  EXPECT_EQ(renderOne(*mapped), before);
  EXPECT_EQ(renderOne(*rebuilt), before);
}

// The damage is done in place to a file no renderer maps at that moment: the cameras' writers
// never change a file in place (they rename a complete one over it), and a mapped file truncated
// in place would fault its reader.
TEST(FloorRasterCache, CorruptOrTruncatedFileIsRebuiltNeverTrusted) {
  CacheSetup s;
  s.make(s.params, s.dir.string());
  const fs::path path = s.file(s.params);
  const auto size = fs::file_size(path);
  const std::vector<std::uint8_t> reference = renderOne(*s.make(s.params, ""));

  // A rebuilt raster renders the reference frame, is written again, and the next one maps it.
  const auto rebuiltFrom = [&](const std::string& why) {
    {
      const auto rebuilt = s.make(s.params, s.dir.string());
      EXPECT_EQ(rebuilt->rasterSource(), RasterSource::kRebuiltBadCache);
      EXPECT_NE(rebuilt->rasterProblem().find(why), std::string::npos) << rebuilt->rasterProblem();
      EXPECT_TRUE(rebuilt->rasterMapped());
      EXPECT_EQ(renderOne(*rebuilt), reference);
    }
    EXPECT_EQ(fs::file_size(path), size);
    const auto next = s.make(s.params, s.dir.string());
    EXPECT_EQ(next->rasterSource(), RasterSource::kLoadedFromCache);
    EXPECT_EQ(renderOne(*next), reference);
  };

  {  // One cell's byte changed in the middle of the file.
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(size / 2));
    f.put('\x5a');
  }
  rebuiltFrom("checksum");

  fs::resize_file(path, size - 1000);
  rebuiltFrom("checksum");
  fs::resize_file(path, 12);
  rebuiltFrom("not a floor raster file");
  fs::resize_file(path, 0);
  rebuiltFrom("empty");

  {  // Garbage of the right size.
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << std::string(size, 'x');
  }
  rebuiltFrom("not a floor raster file");
}

TEST(FloorRasterCache, AFileForOtherInputsIsNotUsed) {
  CacheSetup s;
  s.make(s.params, s.dir.string());
  RenderParams other = s.params;
  other.noise_seed += 1;
  // Another seed, another key and file name.
  EXPECT_NE(floorRasterKey(s.field, other), floorRasterKey(s.field, s.params));
  EXPECT_NE(s.file(other), s.file(s.params));
  // Even under the other inputs' name, the stored key refuses it.
  fs::copy_file(s.file(s.params), s.file(other));
  const auto renderer = s.make(other, s.dir.string());
  EXPECT_EQ(renderer->rasterSource(), RasterSource::kRebuiltBadCache);
  EXPECT_NE(renderer->rasterProblem().find("other inputs"), std::string::npos)
      << renderer->rasterProblem();
  EXPECT_EQ(renderOne(*renderer), renderOne(*s.make(other, "")));

  // Every input the raster depends on changes the key; the mirror does not.
  const std::vector<std::uint8_t> key = floorRasterKey(s.field, s.params);
  auto differs = [&](auto change) {
    RenderParams p = s.params;
    change(p);
    return floorRasterKey(s.field, p) != key;
  };
  EXPECT_TRUE(differs([](RenderParams& p) { p.floor_resolution = 0.01; }));
  EXPECT_TRUE(differs([](RenderParams& p) { p.carpet.g += 1; }));
  EXPECT_TRUE(differs([](RenderParams& p) { p.line.r += 1; }));
  EXPECT_TRUE(differs([](RenderParams& p) { p.carpet_texture[1] += 0.01; }));
  EXPECT_TRUE(differs([](RenderParams& p) { p.lighting.ambient += 0.01; }));
  EXPECT_TRUE(differs([](RenderParams& p) { p.lighting.spots.push_back({}); }));
  EXPECT_TRUE(differs([](RenderParams& p) { p.lighting.windows.gain += 0.1; }));
  EXPECT_FALSE(differs([](RenderParams& p) { p.noise_luma += 1.0; }));  // per frame, not baked
  EXPECT_NE(floorRasterKey(field::loadFieldPreset("fu2004"), s.params), key);
}

TEST(FloorRasterCache, UnwritableDirectoryStillRenders) {
  CacheSetup s;
  fs::create_directories(s.dir.parent_path());
  {
    std::ofstream f(s.dir);  // a file where the directory should be
    f << "x";
  }
  const auto renderer = s.make(s.params, s.dir.string());
  EXPECT_EQ(renderer->rasterSource(), RasterSource::kBuilt);
  EXPECT_NE(renderer->rasterProblem(), "");
  EXPECT_EQ(renderOne(*renderer), renderOne(*s.make(s.params, "")));
}

TEST(FloorRasterCache, MapRefusesDamagedFilesWithAReason) {
  CacheSetup s;
  const std::vector<std::uint8_t> key = floorRasterKey(s.field, s.params);
  std::string problem;
  EXPECT_FALSE(FloorRaster::map((s.dir / "none.bin").string(), key, &problem));
  EXPECT_EQ(problem, "missing");
  fs::create_directories(s.dir);
  const fs::path path = s.dir / "raster.bin";
  // 5 x 6 cells (two tiles by two, partly filled) and 3 x 3.
  FloorRasterLevel fine{0.5, 2.0, 5, 6, {}};
  for (int k = 0; k < 30; ++k)
    fine.cells.push_back(Yuv{static_cast<std::uint8_t>(k), static_cast<std::uint8_t>(100 + k), 7});
  FloorRasterLevel coarse{1.0, 1.0, 3, 3, std::vector<Yuv>(9, Yuv{40, 50, 60})};
  const FloorRaster built = FloorRaster::build(key, {fine, coarse});
  EXPECT_FALSE(built.mapped());
  built.save(path.string());
  EXPECT_EQ(fs::file_size(path), built.size());
  const auto loaded = FloorRaster::map(path.string(), key, &problem);
  ASSERT_TRUE(loaded) << problem;
  EXPECT_TRUE(loaded->mapped());
  EXPECT_EQ(std::vector<std::uint8_t>(loaded->data(), loaded->data() + loaded->size()),
            std::vector<std::uint8_t>(built.data(), built.data() + built.size()));
  ASSERT_EQ(loaded->levels().size(), 2u);
  for (const FloorRaster* r : {&built, &*loaded}) {
    for (const TiledLevel& l : r->levels()) {
      // Every tile a whole cache line.
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(l.tiles) % 64, 0u);
    }
    EXPECT_EQ(r->levels()[0].tile_cols, 2);
    EXPECT_EQ(r->levels()[1].tile_cols, 1);
    const TiledLevel& l = r->levels()[0];
    EXPECT_EQ(l.cols, 5);
    EXPECT_EQ(l.rows, 6);
    EXPECT_DOUBLE_EQ(l.inv_cell, 2.0);
    for (int j = 0; j < 6; ++j) {
      for (int i = 0; i < 5; ++i) {
        EXPECT_EQ(tiledCell(l, i, j).y, j * 5 + i);
        EXPECT_EQ(tiledCell(l, i, j).u, 100 + j * 5 + i);
        EXPECT_EQ(tiledCell(l, i, j).v, 7);
      }
    }
    EXPECT_EQ(tiledCell(r->levels()[1], 2, 2).v, 60);
  }

  // Levels that do not halve are refused even with a good checksum.
  FloorRasterLevel odd = coarse;
  odd.cols = 2;
  odd.cells.resize(6);
  FloorRaster::build(key, {fine, odd}).save(path.string());
  EXPECT_FALSE(FloorRaster::map(path.string(), key, &problem));
  EXPECT_EQ(problem, "levels do not halve");

  std::vector<std::uint8_t> other_key = key;
  other_key.back() ^= 1;
  FloorRaster::build(other_key, {fine, coarse}).save(path.string());
  EXPECT_FALSE(FloorRaster::map(path.string(), key, &problem));
  EXPECT_NE(problem.find("other inputs"), std::string::npos) << problem;

  for (std::size_t cut : {0u, 5u, 12u, 40u, 300u}) {
    built.save(path.string());
    fs::resize_file(path, cut);
    EXPECT_FALSE(FloorRaster::map(path.string(), key, &problem)) << cut;
    EXPECT_NE(problem, "");
  }
  // Inconsistent levels are not tiled.
  FloorRasterLevel short_level = fine;
  short_level.cells.pop_back();
  EXPECT_THROW(FloorRaster::build(key, {short_level}), std::invalid_argument);
}

}  // namespace floor_raster_cache_test
}  // namespace fieldline::camera
