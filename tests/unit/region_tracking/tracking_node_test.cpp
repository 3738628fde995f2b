// The region_tracking node over memq:// with a simulated clock: rendered CAMERA_IMAGE frames in,
// VISION_BALL and VISION_OBSTACLES for every frame and VISION_LINES every third frame out, each
// with the frame's utime; frames it cannot use are counted and produce nothing.
#include "services/region_tracking/tracking_node.hpp"

#include <vector>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/geometry/geometry.hpp"
#include "common/time/clock.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace tracking_node_test {

TEST(TrackingNode, PublishesBallAndObstaclesEveryFrameAndLinesEveryThird) {
  SimCamera sim = SimCamera::load("omni_sim", "msl");
  SimulatedClock clock{1'800'000'000'000'000};
  auto memq = bus::Connection::open("memq://");
  bus::Node camera{{.process = "camera", .robot_id = 2, .status_period_us = 0}, clock, memq};
  bus::Node vision{
      {.process = "region_tracking", .robot_id = 2, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 2, .status_period_us = 0}, clock, memq};

  TrackingNodeOptions options;
  options.mirror = sim.mirror;
  options.colours = sim.table;
  TrackingNode tracking(vision, options);

  std::vector<Utime> ballTimes, obstacleTimes, lineTimes;
  std::vector<ball_observation_t> balls;
  line_contours_t lastLines;
  listener.subscribe(bus::channels::kVisionBall, [&](const ball_observation_t& m) {
    ballTimes.push_back(m.header.utime);
    balls.push_back(m);
  });
  listener.subscribe(bus::channels::kVisionObstacles, [&](const obstacle_observations_t& m) {
    obstacleTimes.push_back(m.header.utime);
  });
  listener.subscribe(bus::channels::kVisionLines, [&](const line_contours_t& m) {
    lineTimes.push_back(m.header.utime);
    lastLines = m;
  });

  const geometry::Pose2 pose{1.0, 0.5, 0.3};
  camera::SimScene scene;
  scene.robot = pose;
  scene.ball = camera::SimBall{geometry::pointRobotToField(pose, {1.5, 0.5}), 0.11};
  scene.robots.push_back({geometry::pointRobotToField(pose, {-2.0, 1.0}), 0.25, false});
  // Renders frame i one period later and publishes it as the camera would.
  auto publishFrame = [&](int i) {
    clock.advance(33'333);
    scene.frame_number = static_cast<std::uint64_t>(i);
    const Utime exposure = clock.now() - 60'000;
    image_t image = sim.renderImage(scene, exposure);
    camera.publish(bus::channels::kCameraImage, image);
    return exposure;
  };
  std::vector<Utime> frameTimes;
  for (int i = 0; i < 7; ++i) {
    frameTimes.push_back(publishFrame(i));
    vision.spinOnce(0);
    for (int k = 0; k < 3; ++k)
      listener.spinOnce(0);
  }

  EXPECT_EQ(tracking.framesProcessed(), 7);
  EXPECT_EQ(ballTimes, frameTimes);
  EXPECT_EQ(obstacleTimes, frameTimes);
  EXPECT_EQ(lineTimes, (std::vector<Utime>{frameTimes[0], frameTimes[3], frameTimes[6]}));
  ASSERT_FALSE(balls.empty());
  EXPECT_TRUE(balls.back().visible);
  EXPECT_NEAR(balls.back().x, 1.5, 0.05);
  EXPECT_NEAR(balls.back().y, 0.5, 0.05);
  EXPECT_GT(lastLines.num_points, 50);
  EXPECT_EQ(lastLines.image_width, 320);
  EXPECT_GT(lastLines.touched_fraction, 0.0f);
  EXPECT_LT(lastLines.touched_fraction, 0.3f);

  // A grey image and one of a foreign aspect ratio are refused and counted, nothing published.
  const std::size_t before = ballTimes.size();
  // A black frame of the given layout, published as the camera would.
  auto publishBlank = [&](int width, int height, int stride, std::int8_t format) {
    image_t image{};
    image.header.utime = clock.now() - 60'000;
    image.width = width;
    image.height = height;
    image.stride = stride;
    image.format = format;
    image.size = stride * height;
    image.data.assign(static_cast<std::size_t>(image.size), 0);
    camera.publish(bus::channels::kCameraImage, image);
  };
  publishBlank(320, 240, 320, image_t::FORMAT_GRAY);
  publishBlank(200, 200, 400, image_t::FORMAT_YUYV);
  // The right aspect ratio but smaller than one cell: refused too, tracking state kept.
  publishBlank(4, 2, 8, image_t::FORMAT_YUYV);
  for (int k = 0; k < 3; ++k)
    vision.spinOnce(0);
  for (int k = 0; k < 3; ++k)
    listener.spinOnce(0);
  EXPECT_EQ(tracking.framesRejected(), 3);
  EXPECT_EQ(ballTimes.size(), before);
  EXPECT_EQ(vision.status().errorCount("image_format"), 1);
  EXPECT_EQ(vision.status().errorCount("frame_size"), 2);
  EXPECT_EQ(vision.status().errorCount("exception"), 0);

  // Good frames go on; the lines cadence counts processed frames only (7 processed so far: the
  // 10th processed frame has lines), and tracking continued without a new initial search.
  const std::size_t linesBefore = lineTimes.size();
  for (int i = 7; i < 10; ++i) {
    publishFrame(i);
    vision.spinOnce(0);
    for (int k = 0; k < 3; ++k)
      listener.spinOnce(0);
  }
  EXPECT_EQ(tracking.framesProcessed(), 10);
  EXPECT_EQ(lineTimes.size(), linesBefore + 1);
  EXPECT_EQ(lastLines.initial_searches, 0);
}

}  // namespace tracking_node_test
}  // namespace fieldline::region_tracking
