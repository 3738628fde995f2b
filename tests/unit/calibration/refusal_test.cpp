// The calibration tools refuse useless output (issue 30, item 3): for an empty frame, frames of
// another field and a table that gives no line points, fieldline-mirror-calibrate and
// fieldline-colour-calibrate throw Refusal (their main() prints it and exits 1) and write
// nothing, not even a staging folder. Paths in a camera preset resolve against the preset's file;
// what a tool stages is only moved into place by commit().
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/core.hpp>

#include "common/camera/colour.hpp"
#include "common/camera/image_io.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"
#include "common/config/paths.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/colour_calibrate/calibrate_app.hpp"
#include "tools/colour_calibrate/image_calibration.hpp"
#include "tools/eval_real/venue_cases.hpp"
#include "tools/mirror_calibrate/app.hpp"

namespace fieldline::calibration {
namespace {

namespace fs = std::filesystem;

class Refusals : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() / ("calibration_refusal_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  // The case's frames written as PNG into the test folder.
  std::vector<std::string> frames(const std::string& manifest) {
    const venue::RenderedVenue v =
        venue::renderVenue(venue::loadVenueCase(config::projectRoot() + "/" + manifest));
    return venue::writeVenue(v, (dir / v.spec.name).string());
  }
  // Nothing but the inputs in the folder: no output, no staging folder.
  void expectNothingWritten() {
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      EXPECT_TRUE(name.starts_with("frame_") || name == "truth.yaml" ||
                  (entry.is_directory() && !name.starts_with(".fieldline-staging")))
          << entry.path();
    }
    EXPECT_FALSE(fs::exists(out()));
  }
  std::string out() const { return (dir / "out.yaml").string(); }

  fs::path dir;
};

TEST_F(Refusals, AnEmptyFrame) {
  const std::string empty = (dir / "frame_empty.png").string();
  camera::writeImage(empty, cv::Mat(240, 320, CV_8UC3, cv::Scalar(0, 0, 0)));
  MirrorCalibrateOptions m;
  m.lines = {empty};
  m.out = out();
  EXPECT_THROW((void)runMirrorCalibrate(m), Refusal);
  AppOptions c;
  c.inputs = {empty};
  c.out = out();
  EXPECT_THROW((void)runApp(c), Refusal);
  expectNothingWritten();
}

TEST_F(Refusals, FramesOfAnotherField) {
  const std::vector<std::string> files = frames("tests/data/calibration/other_field.yaml");
  MirrorCalibrateOptions m;
  m.spots = {files[0] + "," + files[1] + "," + files[2] + "," + files[3]};
  m.field = "msl";
  m.out = out();
  EXPECT_THROW((void)runMirrorCalibrate(m), Refusal);
  AppOptions c;
  c.inputs = files;
  c.field_preset = "msl";
  c.out = out();
  EXPECT_THROW((void)runApp(c), Refusal);
  expectNothingWritten();
  // The same frames calibrate as the field they show.
  c.field_preset = "fu2004";
  EXPECT_EQ(runApp(c), 0);
  EXPECT_TRUE(fs::exists(out()));
  EXPECT_TRUE(camera::loadColourTablePreset(out()).fromLookupTable());
}

TEST_F(Refusals, ATableThatGivesNoLinePoints) {
  const std::vector<std::string> files = frames("tests/data/calibration/no_lines.yaml");
  AppOptions c;
  c.inputs = files;
  c.out = out();
  try {
    (void)runApp(c);
    FAIL() << "expected a refusal";
  } catch (const Refusal& e) {
    EXPECT_NE(std::string(e.what()).find("line"), std::string::npos) << e.what();
  }
  expectNothingWritten();
  // A table without a line class, checked on good frames: no line points, refused by the check.
  const std::vector<std::string> good = frames("tests/data/venue_cases/grey_carpet.yaml");
  std::vector<camera::FrameFile> read;
  std::vector<camera::FrameView> views;
  for (std::size_t i = 0; i < 2; ++i)
    read.push_back(camera::readFrameFile(good[i]));
  for (const camera::FrameFile& f : read)
    views.push_back(f.view());
  std::vector<camera::YuvBox> boxes{{camera::ColourClass::kGreen, {0, 255}, {0, 255}, {0, 255}}};
  const camera::MirrorModel mirror = camera::loadCameraPreset("omni_sim").mirror;
  const TableCheck check = checkTable(mirror, field::loadFieldPreset("msl"), views,
                                      camera::ColourTable(boxes), ImageFitParams{});
  EXPECT_EQ(check.line_points, 0);
  ASSERT_FALSE(check.problems.empty());
  EXPECT_NE(check.problems[0].find("no line points"), std::string::npos) << check.problems[0];
}

TEST(StagedFiles, NothingArrivesBeforeCommitAndNothingStaysWithoutIt) {
  const fs::path dir =
      fs::temp_directory_path() / ("calibration_staged_" + std::to_string(getpid()));
  fs::create_directories(dir);
  {
    StagedFiles staged;
    const std::string at = staged.stage((dir / "a.yaml").string(), "a: 1\n");
    EXPECT_TRUE(fs::exists(at));
    EXPECT_FALSE(fs::exists(dir / "a.yaml"));
    EXPECT_THROW(staged.stage((dir / "sub" / "b.yaml").string(), "x"), std::runtime_error);
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 0);
  {
    StagedFiles staged;
    staged.stage((dir / "a.yaml").string(), "a: 1\n");
    staged.stage((dir / "a.lut").string(), "bytes");
    EXPECT_EQ(staged.commit().size(), 2u);
  }
  EXPECT_TRUE(fs::exists(dir / "a.yaml"));
  EXPECT_TRUE(fs::exists(dir / "a.lut"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2);
  EXPECT_THROW(StagedFiles().stage((dir / "missing" / "c.yaml").string(), "x"), std::runtime_error);
  fs::remove_all(dir);
}

TEST(ConfigPaths, AColourTableResolvesAgainstTheCameraPresetThatNamesIt) {
  EXPECT_EQ(config::resolveAgainst("/a/b/cam.yaml", "camera", "colours.yaml"), "/a/b/colours.yaml");
  EXPECT_EQ(config::resolveAgainst("/a/b/cam.yaml", "camera", "../c/t.yaml"), "/a/c/t.yaml");
  EXPECT_EQ(config::resolveAgainst("/a/b/cam.yaml", "camera", "/x/t.yaml"), "/x/t.yaml");
  EXPECT_EQ(config::resolveAgainst("/a/b/cam.yaml", "camera", "colours_sim"), "colours_sim");
  EXPECT_EQ(config::resolveAgainst("/a/b/c.yaml", "", "venue.lut"), "/a/b/venue.lut");
  // A preset and its table side by side in a venue folder load from any working directory.
  const fs::path dir =
      fs::temp_directory_path() / ("calibration_paths_" + std::to_string(getpid()));
  fs::create_directories(dir / "venue");
  fs::copy_file(config::resolvePreset("camera", "colours_sim"), dir / "venue" / "colours.yaml");
  std::string camera;
  {
    std::ifstream in(config::resolvePreset("camera", "omni_sim"));
    camera.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string from = "colour_table: colours_sim";
  camera.replace(camera.find(from), from.size(), "colour_table: colours.yaml");
  std::ofstream(dir / "venue" / "cam.yaml") << camera;
  const fs::path before = fs::current_path();
  fs::current_path(dir);
  const camera::CameraModel model = camera::loadCameraPreset("venue/cam.yaml");
  EXPECT_EQ(camera::loadColourTablePreset(model.colour_table).yuvLookup(),
            camera::loadColourTablePreset("colours_sim").yuvLookup());
  // The mirror tool writes a path that names the same file from where its output goes.
  EXPECT_EQ(colourTableFor((dir / "robots" / "r1.yaml").string(), model.colour_table),
            "../venue/colours.yaml");
  EXPECT_EQ(colourTableFor("r1.yaml", "colours_sim"), "colours_sim");
  fs::current_path(before);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fieldline::calibration
