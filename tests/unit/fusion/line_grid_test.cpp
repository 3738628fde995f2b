// The layer-2 lookup grid: values against the exact field model, the force field's direction,
// and the disk cache (round trip, corrupt, truncated and foreign files rebuilt, never used).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/field/field_model.hpp"
#include "services/fusion/line_grid.hpp"

namespace fieldline::fusion {
namespace line_grid_test {

namespace fs = std::filesystem;

// A coarse grid keeps these tests fast; the geometry does not depend on the cell size.
LineGridSettings coarse() {
  LineGridSettings s;
  s.cell_m = 0.05;
  return s;
}

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("fieldline_grid_test_" + std::to_string(std::random_device{}()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(LineGrid, DistanceMatchesTheFieldModelWithinACell) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const LineGrid grid = LineGrid::build(field, coarse());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-11.0, 11.0), y(-7.5, 7.5);
  for (int k = 0; k < 2000; ++k) {
    const field::Vec2 p(x(rng), y(rng));
    double d = -1.0;
    ASSERT_TRUE(grid.distance(p.x(), p.y(), d));
    // Distance is 1-Lipschitz: bilinear interpolation errs by at most a cell diagonal / 2.
    EXPECT_NEAR(d, field.distance(p), 0.05 * std::sqrt(2.0) / 2.0) << p.transpose();
  }
}

TEST(LineGrid, GradientIsTheInterpolationsDerivative) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const LineGrid grid = LineGrid::build(field, coarse());
  // Inside one cell, away from lines: central differences of distance() equal distanceGradient().
  for (const field::Vec2& p : {field::Vec2(3.013, 2.521), field::Vec2(-6.21, -4.07)}) {
    double d, gx, gy, dxp, dxm, dyp, dym;
    ASSERT_TRUE(grid.distanceGradient(p.x(), p.y(), d, gx, gy));
    const double h = 1e-4;
    ASSERT_TRUE(grid.distance(p.x() + h, p.y(), dxp) && grid.distance(p.x() - h, p.y(), dxm));
    ASSERT_TRUE(grid.distance(p.x(), p.y() + h, dyp) && grid.distance(p.x(), p.y() - h, dym));
    EXPECT_NEAR(gx, (dxp - dxm) / (2 * h), 1e-3);
    EXPECT_NEAR(gy, (dyp - dym) / (2 * h), 1e-3);
    // Away from the lines the distance grows at unit rate.
    EXPECT_NEAR(std::hypot(gx, gy), 1.0, 0.05);
  }
}

TEST(LineGrid, ForcePullsTowardTheNearestLine) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  const LineGrid grid = LineGrid::build(field, coarse());
  // 20 cm to the side of the halfway line, far from the centre circle: pulled back by ~20 cm.
  double d, fx, fy;
  ASSERT_TRUE(grid.distanceForce(0.2, 4.5, d, fx, fy));
  EXPECT_NEAR(fx, -0.2, 0.02);
  EXPECT_NEAR(fy, 0.0, 0.02);
  ASSERT_TRUE(grid.distanceForce(-0.15, 4.5, d, fx, fy));
  EXPECT_NEAR(fx, 0.15, 0.02);
  // Outside the grid and for NaN: no answer.
  EXPECT_FALSE(grid.distanceForce(50.0, 0.0, d, fx, fy));
  EXPECT_FALSE(grid.distance(std::nan(""), 0.0, d));
}

TEST(LineGrid, KeyDependsOnFieldAndSettings) {
  const field::FieldModel msl = field::loadFieldPreset("msl");
  const field::FieldModel fu = field::loadFieldPreset("fu2004");
  LineGridSettings other = coarse();
  other.cell_m = 0.04;
  EXPECT_EQ(lineGridKey(msl, coarse()), lineGridKey(msl, coarse()));
  EXPECT_NE(lineGridKey(msl, coarse()), lineGridKey(fu, coarse()));
  EXPECT_NE(lineGridKey(msl, coarse()), lineGridKey(msl, other));
  EXPECT_NE(lineGridFileName(lineGridKey(msl, coarse())),
            lineGridFileName(lineGridKey(fu, coarse())));
}

TEST(LineGrid, CacheRoundTripsExactly) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  TempDir dir;
  GridSource source;
  const LineGrid built = loadOrBuildLineGrid(field, coarse(), dir.path().string(), &source);
  EXPECT_EQ(source, GridSource::kBuilt);
  const fs::path file = dir.path() / lineGridFileName(built.key());
  ASSERT_TRUE(fs::exists(file));

  const LineGrid loaded = loadOrBuildLineGrid(field, coarse(), dir.path().string(), &source);
  EXPECT_EQ(source, GridSource::kLoadedFromCache);
  ASSERT_EQ(loaded.columns(), built.columns());
  ASSERT_EQ(loaded.rows(), built.rows());
  EXPECT_EQ(loaded.originX(), built.originX());
  EXPECT_EQ(loaded.cellSize(), built.cellSize());
  ASSERT_EQ(loaded.nodes().size(), built.nodes().size());
  for (std::size_t k = 0; k < built.nodes().size(); ++k) {
    ASSERT_EQ(loaded.nodes()[k].distance, built.nodes()[k].distance);
    ASSERT_EQ(loaded.nodes()[k].force_x, built.nodes()[k].force_x);
    ASSERT_EQ(loaded.nodes()[k].force_y, built.nodes()[k].force_y);
  }
}

// Damages the cache file with `damage`, checks the loader rejects it and the next load rebuilds
// a correct grid and rewrites a good file.
void expectRebuiltAfter(const std::function<void(const fs::path&)>& damage, const char* what) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  TempDir dir;
  const LineGrid built = loadOrBuildLineGrid(field, coarse(), dir.path().string());
  const fs::path file = dir.path() / lineGridFileName(built.key());
  damage(file);
  std::string problem;
  EXPECT_FALSE(loadLineGrid(file.string(), built.key(), &problem)) << what;
  EXPECT_FALSE(problem.empty()) << what;

  GridSource source;
  const LineGrid again =
      loadOrBuildLineGrid(field, coarse(), dir.path().string(), &source, &problem);
  EXPECT_EQ(source, GridSource::kRebuiltBadCache) << what;
  ASSERT_EQ(again.nodes().size(), built.nodes().size());
  EXPECT_EQ(again.nodes()[12345].distance, built.nodes()[12345].distance);
  // The rewritten file is good again.
  EXPECT_TRUE(loadLineGrid(file.string(), built.key(), &problem)) << what << ": " << problem;
}

TEST(LineGrid, CorruptCacheFileIsRebuilt) {
  expectRebuiltAfter(
      [](const fs::path& file) {
        std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(static_cast<std::streamoff>(fs::file_size(file) / 2));
        const char garbage = 0x5a;
        f.write(&garbage, 1);
      },
      "one byte flipped");
}

TEST(LineGrid, TruncatedCacheFileIsRebuilt) {
  expectRebuiltAfter([](const fs::path& file) { fs::resize_file(file, fs::file_size(file) - 9); },
                     "truncated");
  expectRebuiltAfter([](const fs::path& file) { fs::resize_file(file, 20); }, "header only");
  expectRebuiltAfter([](const fs::path& file) { fs::resize_file(file, 0); }, "empty");
}

TEST(LineGrid, GarbageAndForeignCacheFilesAreRebuilt) {
  expectRebuiltAfter(
      [](const fs::path& file) {
        std::ofstream f(file, std::ios::binary | std::ios::trunc);
        for (int k = 0; k < 4096; ++k)
          f.put(static_cast<char>(k * 37));
      },
      "garbage");
  // A valid grid of another field under this field's name.
  expectRebuiltAfter(
      [](const fs::path& file) {
        saveLineGrid(LineGrid::build(field::loadFieldPreset("msl"), coarse()), file.string());
      },
      "another field's grid");
}

TEST(LineGrid, UnwritableCacheStillGivesTheGrid) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  TempDir dir;
  // The cache "directory" is a file: nothing can be written under it.
  const fs::path blocked = dir.path() / "not_a_directory";
  std::ofstream(blocked) << "x";
  GridSource source;
  std::string problem;
  const LineGrid grid =
      loadOrBuildLineGrid(field, coarse(), (blocked / "cache").string(), &source, &problem);
  EXPECT_EQ(source, GridSource::kBuilt);
  EXPECT_FALSE(problem.empty());
  EXPECT_EQ(grid.nodes().size(), LineGrid::build(field, coarse()).nodes().size());
}

TEST(LineGrid, BadSettingsThrow) {
  const field::FieldModel field = field::loadFieldPreset("fu2004");
  LineGridSettings s = coarse();
  s.cell_m = 0.0;
  EXPECT_THROW(LineGrid::build(field, s), std::invalid_argument);
  s.cell_m = std::nan("");
  EXPECT_THROW(LineGrid::build(field, s), std::invalid_argument);
  s.cell_m = 1e-4;  // too many nodes
  EXPECT_THROW(LineGrid::build(field, s), std::invalid_argument);
  s = coarse();
  s.margin_m = -1.0;
  EXPECT_THROW(LineGrid::build(field, s), std::invalid_argument);
}

}  // namespace line_grid_test
}  // namespace fieldline::fusion
