#include "services/camera/floor_raster_cache.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
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

std::vector<std::uint8_t> renderOne(SimRenderer& renderer) {
  SimScene scene;
  scene.robot = geometry::Pose2{-1.3, 0.8, 0.4};
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

  const auto loaded = s.make(s.params, s.dir.string());
  EXPECT_EQ(loaded->rasterSource(), RasterSource::kLoadedFromCache);
  const auto uncached = s.make(s.params, "");
  EXPECT_EQ(uncached->rasterSource(), RasterSource::kBuilt);

  const std::vector<std::uint8_t> a = renderOne(*uncached);
  EXPECT_EQ(renderOne(*built), a);
  EXPECT_EQ(renderOne(*loaded), a);
  for (const Vec2& p : {Vec2(0.0, 0.0), Vec2(-3.1, 1.7), Vec2(5.9, -3.9)}) {
    EXPECT_EQ(loaded->floorColour(p).y, uncached->floorColour(p).y);
    EXPECT_EQ(loaded->floorColour(p).u, uncached->floorColour(p).u);
  }
}

TEST(FloorRasterCache, CorruptOrTruncatedFileIsRebuiltNeverTrusted) {
  CacheSetup s;
  s.make(s.params, s.dir.string());
  const fs::path path = s.file(s.params);
  const auto size = fs::file_size(path);
  const std::vector<std::uint8_t> reference = renderOne(*s.make(s.params, ""));

  {  // One cell's byte changed in the middle of the file.
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(size / 2));
    f.put('\x5a');
  }
  const auto corrupt = s.make(s.params, s.dir.string());
  EXPECT_EQ(corrupt->rasterSource(), RasterSource::kRebuiltBadCache);
  EXPECT_NE(corrupt->rasterProblem().find("checksum"), std::string::npos)
      << corrupt->rasterProblem();
  EXPECT_EQ(renderOne(*corrupt), reference);
  // Rewritten: the next one reads it.
  EXPECT_EQ(s.make(s.params, s.dir.string())->rasterSource(), RasterSource::kLoadedFromCache);

  fs::resize_file(path, size - 1000);
  const auto truncated = s.make(s.params, s.dir.string());
  EXPECT_EQ(truncated->rasterSource(), RasterSource::kRebuiltBadCache);
  EXPECT_EQ(renderOne(*truncated), reference);
  EXPECT_EQ(fs::file_size(path), size);

  {  // Garbage of the right size.
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << std::string(size, 'x');
  }
  EXPECT_EQ(s.make(s.params, s.dir.string())->rasterSource(), RasterSource::kRebuiltBadCache);
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

TEST(FloorRasterCache, LoadRefusesDamagedFilesWithAReason) {
  CacheSetup s;
  const std::vector<std::uint8_t> key = floorRasterKey(s.field, s.params);
  std::string problem;
  EXPECT_FALSE(loadFloorRaster((s.dir / "none.bin").string(), key, &problem));
  EXPECT_EQ(problem, "missing");
  fs::create_directories(s.dir);
  const fs::path path = s.dir / "raster.bin";
  FloorRasterLevel fine{0.5, 2.0, 3, 2, std::vector<Yuv>(6, Yuv{10, 20, 30})};
  FloorRasterLevel coarse{1.0, 1.0, 2, 1, std::vector<Yuv>(2, Yuv{40, 50, 60})};
  saveFloorRaster(path.string(), key, {fine, coarse});
  const auto loaded = loadFloorRaster(path.string(), key, &problem);
  ASSERT_TRUE(loaded) << problem;
  ASSERT_EQ(loaded->size(), 2u);
  EXPECT_EQ((*loaded)[1].cells[1].v, 60);
  EXPECT_DOUBLE_EQ((*loaded)[0].inv_cell, 2.0);

  // Levels that do not halve are refused even with a good checksum.
  FloorRasterLevel odd = coarse;
  odd.cols = 1;
  odd.cells.resize(1);
  saveFloorRaster(path.string(), key, {fine, odd});
  EXPECT_FALSE(loadFloorRaster(path.string(), key, &problem));
  EXPECT_EQ(problem, "levels do not halve");

  std::vector<std::uint8_t> other_key = key;
  other_key.back() ^= 1;
  saveFloorRaster(path.string(), other_key, {fine, coarse});
  EXPECT_FALSE(loadFloorRaster(path.string(), key, &problem));

  for (std::size_t cut : {0u, 5u, 12u, 40u}) {
    saveFloorRaster(path.string(), key, {fine, coarse});
    fs::resize_file(path, cut);
    EXPECT_FALSE(loadFloorRaster(path.string(), key, &problem)) << cut;
    EXPECT_NE(problem, "");
  }
}

}  // namespace floor_raster_cache_test
}  // namespace fieldline::camera
