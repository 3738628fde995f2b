// fieldline-colour-calibrate's steps (issue 12, part 1): the ball painted over a rendered frame
// in the palette's orange becomes the orange class of the calibrated table (nothing else in the
// frame does); the table written as a full lookup table reads back cell for cell through the
// preset loader; a lookup table as the base keeps its other classes; bad paintings are refused.
#include "tools/colour_calibrate/calibrate_app.hpp"

#include <filesystem>

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/imgproc.hpp>

#include "common/camera/image_io.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::calibration {
namespace {

namespace fs = std::filesystem;

TEST(CalibrateApp, ABallPaintedOverTheFrameBecomesTheOrangeClass) {
  region_tracking::SimCamera sim = region_tracking::SimCamera::load("omni_sim", "msl");
  const geometry::Pose2 pose{1.0, 0.5, 0.3};
  camera::SimScene scene;
  scene.robot = pose;
  scene.ball = camera::SimBall{{2.0, 1.2}, 0.11};
  // The ball redder than the shipped table's orange expects: the base table misses it.
  sim.renderer->realism().setParams({.chroma_shift = {-6.0, 14.0}});
  const camera::FrameView view = sim.render(scene);
  const geometry::Vec2 ballRobot = geometry::pointFieldToRobot(pose, {2.0, 1.2});
  const std::optional<camera::Vec2> centre =
      sim.mirror.robotPointToImage({ballRobot.x(), ballRobot.y(), 0.11});
  ASSERT_TRUE(centre);

  // Paint a small disk on the ball's centre over the frame itself.
  cv::Mat painted = camera::toBgrImage(view);
  const cv::Point c(static_cast<int>(std::lround(centre->x())),
                    static_cast<int>(std::lround(centre->y())));
  cv::circle(painted, c, 2, cv::Scalar(0, 128, 255), cv::FILLED);
  const std::vector<UserMask> masks = masksFromPainting(painted, view);
  ASSERT_EQ(masks.size(), 1u);
  EXPECT_EQ(masks[0].colour, camera::ColourClass::kOrange);

  const Calibration calibration =
      calibrate(sim.mirror, sim.field, {{view, pose}}, masks, sim.table.boxes(), FitParams{});
  const camera::ColourTable table = finalTable(calibration, sim.table);
  // The painted ball (and 3 px around it) is not carpet: fewer green samples than unpainted.
  const Calibration unpainted =
      calibrate(sim.mirror, sim.field, {{view, pose}}, {}, sim.table.boxes(), FitParams{});
  EXPECT_LT(calibration.fits[0].samples, unpainted.fits[0].samples - 20);
  // Painted "no class" (cyan): kept out of the samples, no class fitted.
  cv::Mat marked = camera::toBgrImage(view);
  cv::circle(marked, c, 2, cv::Scalar(255, 255, 0), cv::FILLED);
  const std::vector<UserMask> ignore = masksFromPainting(marked, view);
  ASSERT_EQ(ignore.size(), 1u);
  EXPECT_EQ(ignore[0].colour, camera::ColourClass::kUnknown);
  const Calibration ignored =
      calibrate(sim.mirror, sim.field, {{view, pose}}, ignore, sim.table.boxes(), FitParams{});
  EXPECT_EQ(ignored.fits.size(), 2u);
  EXPECT_EQ(ignored.fits[0].samples, calibration.fits[0].samples);
  int orange = 0, carpetOrange = 0;
  for (int dv = -1; dv <= 1; ++dv) {
    for (int du = -1; du <= 1; ++du) {
      orange += table.classifyPixel(view, c.x + du, c.y + dv) == camera::ColourClass::kOrange;
    }
  }
  EXPECT_GE(orange, 7);
  for (int v = 0; v < view.height; v += 4) {
    for (int u = 0; u < view.width; u += 4) {
      if (std::hypot(u - c.x, v - c.y) < 12) continue;
      carpetOrange += table.classifyPixel(view, u, v) == camera::ColourClass::kOrange;
    }
  }
  EXPECT_LE(carpetOrange, 3);

  // Another size, or a painting without a palette colour.
  EXPECT_THROW((void)masksFromPainting(cv::Mat(10, 10, CV_8UC3), view), std::invalid_argument);
  EXPECT_TRUE(masksFromPainting(camera::toBgrImage(view), view).empty());
}

TEST(CalibrateApp, TheTableWrittenAsALookupTableReadsBackAndServesAsABase) {
  const fs::path dir =
      fs::temp_directory_path() / ("calibrate_app_test_" + std::to_string(getpid()));
  fs::create_directories(dir);
  AppOptions o;
  o.render = true;
  o.poses = {"-6.0,1.5,0.4"};
  o.lut = true;
  o.out = (dir / "venue.yaml").string();
  ASSERT_EQ(runApp(o), 0);
  ASSERT_TRUE(fs::exists(dir / "venue.lut"));
  const camera::ColourTable written = camera::loadColourTablePreset(o.out);
  EXPECT_TRUE(written.fromLookupTable());
  EXPECT_LT(fs::file_size(dir / "venue.lut"), 150000u);

  // Again with that lookup table as the base: its orange (from the camera's boxes) survives, its
  // green is replaced by the new fit.
  AppOptions again = o;
  again.base = o.out;
  again.out = (dir / "again.yaml").string();
  ASSERT_EQ(runApp(again), 0);
  const camera::ColourTable second = camera::loadColourTablePreset(again.out);
  const camera::ColourTable shipped = camera::loadColourTablePreset("colours_sim");
  long orangeCells = 0, orangeKept = 0;
  for (std::size_t i = 0; i < written.yuvLookup().size(); ++i) {
    if (written.yuvLookup()[i] != camera::ColourClass::kOrange) continue;
    ++orangeCells;
    orangeKept += second.yuvLookup()[i] == camera::ColourClass::kOrange;
  }
  EXPECT_GT(orangeCells, 100);
  EXPECT_GT(static_cast<double>(orangeKept) / orangeCells, 0.95);
  EXPECT_EQ(second.yuvLookup(), written.yuvLookup());  // same frame, same fit
  (void)shipped;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fieldline::calibration
