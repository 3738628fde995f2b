// fieldline-tracking-png on any frame (issue 12, part 4): a rendered frame saved as PNG
// (tests/data/tracking_png) tracks to line points on the model's lines; the CSV reads back
// through the feature tool's reader; the JSON holds every point with its image coordinates; raw
// YUYV reads with its size and is refused with another; a frame of another aspect ratio than
// the camera is refused with a message naming the fix; a real grey frame runs and finds no line.
#include "tools/tracking_png/tracking_png.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/perception/line_points_csv.hpp"
#include "tools/colour_calibrate/colour_calibration.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::tracking_png {
namespace {

namespace fs = std::filesystem;

// Rendered by `fieldline-colour-calibrate --render --pose 0.5,0.8,0.3 --save-frame ...`.
const std::string kRenderedPng = "tests/data/tracking_png/rendered_0.5_0.8_0.3.png";
const geometry::Pose2 kRenderedPose{0.5, 0.8, 0.3};

fs::path tempPath(const std::string& name) {
  return fs::temp_directory_path() / ("tracking_png_test_" + std::to_string(::getpid()) + name);
}

TEST(TrackingPng, FrameSizeParsesAndRefusesNonsense) {
  const camera::FrameSize s = camera::parseFrameSize("320x240");
  EXPECT_EQ(s.width, 320);
  EXPECT_EQ(s.height, 240);
  EXPECT_THROW(camera::parseFrameSize("320"), std::invalid_argument);
  EXPECT_THROW(camera::parseFrameSize("320x240x3"), std::invalid_argument);
  EXPECT_THROW(camera::parseFrameSize("-2x4"), std::invalid_argument);
  EXPECT_THROW(camera::parseFrameSize("321x240"), std::invalid_argument);
  EXPECT_EQ(camera::parseFrameSize("321x240", false).width, 321);
}

TEST(TrackingPng, ARenderedFrameFromAPngGivesLinePointsOnTheModelLines) {
  const std::unique_ptr<TrackedFrame> tracked =
      trackFile("omni_sim", "", region_tracking::defaultVisionParams(), {kRenderedPng, {}, 5});
  const perception::LinePoints& lines = tracked->result.lines;
  ASSERT_GT(lines.points.size(), 100u);
  const field::FieldModel field = field::loadFieldPreset("msl");
  const calibration::LineScore score =
      calibration::scoreLinePoints(tracked->mirror, field, kRenderedPose, lines, {});
  EXPECT_GE(score.precision, 0.95);
  EXPECT_GE(score.recall, 0.85);

  // The drawing: the frame enlarged, with something drawn over it.
  const cv::Mat image = drawTracking(*tracked, 2, true);
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 480);
}

TEST(TrackingPng, TheCsvReadsBackThroughTheFeatureToolsReader) {
  const std::unique_ptr<TrackedFrame> tracked =
      trackFile("omni_sim", "", region_tracking::defaultVisionParams(), {kRenderedPng, {}, 5});
  const perception::LinePoints& lines = tracked->result.lines;
  std::stringstream csv;
  perception::writeLinePointsCsv(csv, lines);
  const perception::LinePoints back = perception::readLinePointsCsv(csv, "csv");
  ASSERT_EQ(back.points.size(), lines.points.size());
  ASSERT_EQ(back.sequences, lines.sequences);
  for (std::size_t i = 0; i < lines.points.size(); ++i) {
    EXPECT_NEAR(back.points[i].x, lines.points[i].x, 1e-4);
    EXPECT_NEAR(back.points[i].y, lines.points[i].y, 1e-4);
  }
}

TEST(TrackingPng, TheJsonHoldsEveryPointWithItsImageCoordinates) {
  const std::unique_ptr<TrackedFrame> tracked =
      trackFile("omni_sim", "", region_tracking::defaultVisionParams(), {kRenderedPng, {}, 5});
  std::stringstream json;
  writeDetectionsJson(json, *tracked);
  const std::string text = json.str();
  EXPECT_EQ(text.rfind("{\"width\":320,\"height\":240,\"line_sequences\":[[", 0), 0u) << text;
  std::size_t count = 0;
  for (std::size_t at = text.find("{\"u\":"); at != std::string::npos;
       at = text.find("{\"u\":", at + 1)) {
    ++count;
  }
  const std::size_t ball = tracked->result.ball.visible ? 1 : 0;
  EXPECT_EQ(count, tracked->result.lines.points.size() + ball);
  const perception::LinePoint& first = tracked->result.lines.points.front();
  char expected[80];
  std::snprintf(expected, sizeof expected, "{\"u\":%.2f,\"v\":%.2f,", first.u, first.v);
  EXPECT_NE(text.find(expected), std::string::npos) << expected;
  EXPECT_EQ(text.back(), '\n');
}

TEST(TrackingPng, RawYuyvReadsWithItsSizeAndIsRefusedWithAnother) {
  region_tracking::SimCamera sim = region_tracking::SimCamera::load("omni_sim", "msl");
  camera::SimScene scene;
  scene.robot = kRenderedPose;
  sim.render(scene);
  const fs::path raw = tempPath(".yuyv");
  {
    std::ofstream out(raw, std::ios::binary);
    out.write(reinterpret_cast<const char*>(sim.frame.data()),
              static_cast<std::streamsize>(sim.frame.size()));
  }
  const std::unique_ptr<TrackedFrame> tracked = trackFile(
      "omni_sim", "", region_tracking::defaultVisionParams(), {raw.string(), {{320, 240}}, 5});
  EXPECT_EQ(tracked->view.format, camera::PixelFormat::kYuyv);
  const field::FieldModel field = field::loadFieldPreset("msl");
  const calibration::LineScore score = calibration::scoreLinePoints(
      tracked->mirror, field, kRenderedPose, tracked->result.lines, {});
  EXPECT_GE(score.precision, 0.95);
  EXPECT_GE(score.recall, 0.85);
  try {
    (void)camera::readFrameFile(raw.string(), camera::FrameSize{320, 200});
    ADD_FAILURE() << "a wrong size was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("expected 128000"), std::string::npos) << e.what();
  }
  fs::remove(raw);
}

TEST(TrackingPng, AFrameOfAnotherAspectRatioIsRefusedNamingTheCameraOption) {
  const fs::path square = tempPath("_square.png");
  cv::imwrite(square.string(), cv::Mat(100, 100, CV_8UC3, cv::Scalar(90, 90, 90)));
  try {
    (void)trackFile("omni_sim", "", region_tracking::defaultVisionParams(),
                    {square.string(), {}, 1});
    ADD_FAILURE() << "a square frame was accepted for a 4:3 camera";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--camera"), std::string::npos) << e.what();
  }
  fs::remove(square);
  EXPECT_THROW((void)trackFile("omni_sim", "", region_tracking::defaultVisionParams(),
                               {"tests/data/tracking_png/missing.png", {}, 1}),
               std::runtime_error);
}

TEST(TrackingPng, AGreyFrameOfAnotherCameraRunsAndFindsNoLine) {
  // A grey frame of the 460x460 layout of a real robot (no green: nothing to track lines on).
  const fs::path grey = tempPath("_grey.png");
  cv::Mat image(460, 460, CV_8UC1, cv::Scalar(120));
  cv::circle(image, {231, 228}, 120, cv::Scalar(250), 6);
  cv::imwrite(grey.string(), image);
  const std::unique_ptr<TrackedFrame> tracked =
      trackFile("tests/data/tracking_png/cnc_460_guess.yaml", "",
                region_tracking::defaultVisionParams(), {grey.string(), {}, 3});
  EXPECT_EQ(tracked->view.width, 460);
  EXPECT_EQ(tracked->result.lines.points.size(), 0u);
  EXPECT_FALSE(tracked->result.ball.visible);
  fs::remove(grey);
}

TEST(TrackingPng, ARenderedDriveFindsTheBallWhereItLies) {
  RenderRequest request;
  request.pose = {1.0, 0.5, 0.3};
  request.ball = std::array<double, 2>{2.0, 1.2};
  request.frames = 3;
  const std::unique_ptr<TrackedFrame> tracked =
      trackRendered("omni_sim", "", region_tracking::defaultVisionParams(), request);
  ASSERT_TRUE(tracked->result.ball.visible);
  const geometry::Pose2 pose{1.0, 0.5, 0.3};
  const Eigen::Vector2d field =
      geometry::pointRobotToField(pose, {tracked->result.ball.x, tracked->result.ball.y});
  EXPECT_NEAR(field.x(), 2.0, 0.15);
  EXPECT_NEAR(field.y(), 1.2, 0.15);
}

}  // namespace
}  // namespace fieldline::tracking_png
