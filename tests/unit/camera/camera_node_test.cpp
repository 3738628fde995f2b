// The camera node over memq:// with a simulated clock: SIM_WORLD in, CAMERA_IMAGE out with the
// exposure time as utime and the configured latency; real sources re-stamped on receipt; the
// LCM log reader.
#include "services/camera/camera_node.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/camera/colour.hpp"
#include "common/geometry/geometry.hpp"
#include "common/msg/image.hpp"
#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"
#include "services/camera/log_source.hpp"

namespace fieldline::camera {
namespace camera_node_test {

world_state_t makeWorld(Utime utime) {
  world_state_t w;
  w.header.utime = utime;
  w.field = "msl";
  w.scenario = "test";
  w.num_robots = 2;
  w.robot_id = {2, 5};
  w.robot_x = {1.0, -3.0};
  w.robot_y = {0.5, 2.0};
  w.robot_phi = {0.3, 0.0};
  w.robot_vx = {0.5, 0.0};
  w.robot_vy = {0.0, 0.0};
  w.robot_omega = {0.2, 0.0};
  w.robot_kidnaps = {0, 0};
  w.num_opponents = 1;
  w.opponent_x = {4.0};
  w.opponent_y = {-2.0};
  w.opponent_phi = {0.0};
  w.opponent_radius = {0.3f};
  w.ball_x = 2.5;
  w.ball_y = 0.9;
  w.ball_vx = 0.0;
  w.ball_vy = 0.0;
  w.ball_radius = 0.11f;
  return w;
}

TEST(SceneFromWorld, ExtrapolatesToTheExposureTime) {
  const world_state_t w = makeWorld(1'000'000);
  SimScene scene;
  ASSERT_TRUE(sceneFromWorld(w, 2, 1'100'000, 0.008, scene));
  const SimScene* s = &scene;
  EXPECT_NEAR(s->robot.x, 1.0 + 0.5 * 0.1, 1e-12);
  EXPECT_NEAR(s->robot.y, 0.5, 1e-12);
  EXPECT_NEAR(s->robot.phi, 0.3 + 0.2 * 0.1, 1e-12);
  ASSERT_EQ(s->robots.size(), 2u);  // robot 5 (teammate) and the opponent
  EXPECT_TRUE(s->robots[0].teammate);
  EXPECT_FALSE(s->robots[1].teammate);
  EXPECT_NEAR(s->robots[1].radius, 0.3, 1e-6);
  ASSERT_TRUE(s->ball);
  EXPECT_NEAR(s->ball->position.x(), 2.5, 1e-12);
  EXPECT_FALSE(sceneFromWorld(w, 4, 1'100'000, 0.008, scene));
}

TEST(SceneBetweenWorlds, InterpolatesAlongTheShorterArcAndNotAcrossAJump) {
  world_state_t a = makeWorld(1'000'000);
  world_state_t b = makeWorld(1'010'000);
  // Robot 2 turns through +-pi: 3.0 to -3.1 is 0.183 rad counter-clockwise. `a` carried on with
  // its own turn rate (4 rad/s) would miss the pose 4 ms later by 0.057 rad.
  const double turn = 2.0 * M_PI - 6.1;
  a.robot_phi = {3.0, 0.0};
  a.robot_omega = {4.0, 0.0};
  b.robot_phi = {-3.1, 0.0};
  b.robot_omega = {turn / 0.01, 0.0};
  b.robot_x = {1.02, -3.0};
  b.robot_y = {0.49, 2.03};  // the teammate moves too
  b.opponent_x = {3.98};
  b.ball_x = 2.53;
  SimScene scene;
  ASSERT_EQ(sceneBetweenWorlds(a, b, 2, 1'004'000, 0.008, scene), ScenePose::kInterpolated);
  EXPECT_NEAR(geometry::angleDiff(scene.robot.phi, 3.0 + 0.4 * turn), 0.0, 1e-6);
  EXPECT_GT(std::abs(geometry::angleDiff(scene.robot.phi, 3.0 + 4.0 * 0.004)), 0.05);
  EXPECT_NEAR(scene.robot.x, 1.0 + 0.4 * 0.02, 1e-9);
  EXPECT_NEAR(scene.robot.y, 0.5 - 0.4 * 0.01, 1e-9);
  EXPECT_NEAR(scene.omega, turn / 0.01, 1e-9);
  ASSERT_EQ(scene.robots.size(), 2u);
  EXPECT_NEAR(scene.robots[0].position.y(), 2.0 + 0.4 * 0.03, 1e-9);
  EXPECT_NEAR(scene.robots[1].position.x(), 4.0 - 0.4 * 0.02, 1e-9);
  ASSERT_TRUE(scene.ball);
  EXPECT_NEAR(scene.ball->position.x(), 2.5 + 0.4 * 0.03, 1e-9);

  // Kidnapped in between: carried from `a` (its pose and turn rate), as without `b`.
  b.robot_kidnaps = {1, 0};
  b.robot_x = {-2.0, -3.0};
  ASSERT_EQ(sceneBetweenWorlds(a, b, 2, 1'004'000, 0.008, scene), ScenePose::kExtrapolated);
  EXPECT_NEAR(scene.robot.x, 1.0 + 0.5 * 0.004, 1e-9);
  EXPECT_NEAR(scene.robot.phi, 3.0 + 4.0 * 0.004, 1e-9);
  // Teleported without a kidnap count (a jump of 3 m, or of more than 1 rad): the same.
  b.robot_kidnaps = {0, 0};
  ASSERT_EQ(sceneBetweenWorlds(a, b, 2, 1'004'000, 0.008, scene), ScenePose::kExtrapolated);
  b.robot_x = {1.02, -3.0};
  b.robot_phi = {1.5, 0.0};
  ASSERT_EQ(sceneBetweenWorlds(a, b, 2, 1'004'000, 0.008, scene), ScenePose::kExtrapolated);
  EXPECT_NEAR(scene.robot.phi, 3.0 + 4.0 * 0.004, 1e-9);
  // The ball placed elsewhere: the robot interpolated, the ball where `a` has it.
  b.robot_phi = {-3.1, 0.0};
  b.ball_x = -1.0;
  ASSERT_EQ(sceneBetweenWorlds(a, b, 2, 1'004'000, 0.008, scene), ScenePose::kInterpolated);
  EXPECT_NEAR(scene.ball->position.x(), 2.5, 1e-12);
  // States that do not bracket the time, or too far apart: carried from `a`.
  EXPECT_EQ(sceneBetweenWorlds(a, b, 2, 1'012'000, 0.008, scene), ScenePose::kExtrapolated);
  b.header.utime = 1'060'000;
  EXPECT_EQ(sceneBetweenWorlds(a, b, 2, 1'004'000, 0.008, scene), ScenePose::kExtrapolated);
  EXPECT_EQ(sceneBetweenWorlds(a, b, 4, 1'004'000, 0.008, scene), ScenePose::kMissing);
}

struct Received {
  std::vector<image_t> images;
};

// A robot turning faster and faster: heading 0.3 + 2 s + 10 s^2 at s seconds after `start`,
// published with the mean turn rate since the previous state 10 ms earlier (as world_sim does).
world_state_t turningWorld(Utime start, Utime utime) {
  const auto phi = [start](Utime t) {
    const double s = static_cast<double>(t - start) * 1e-6;
    return 0.3 + 2.0 * s + 10.0 * s * s;
  };
  world_state_t w = makeWorld(utime);
  w.robot_vx = {0.0, 0.0};
  w.robot_phi = {geometry::normalizeAngle(phi(utime)), 0.0};
  w.robot_omega = {(phi(utime) - phi(utime - 10'000)) / 0.01, 0.0};
  return w;
}

TEST(SimCameraNode, RendersEachFrameBetweenTheWorldStatesAroundItsExposure) {
  SimulatedClock clock;
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera_node{{.process = "camera", .robot_id = 2, .status_period_us = 0}, clock, memq};
  const bus::BusId sim_bus = camera_node.addBus(memq);
  bus::Node harness{{.process = "harness", .robot_id = 0, .status_period_us = 0}, clock, memq};
  Received got;
  harness.subscribe(bus::channels::kCameraImage,
                    [&](const image_t& m) { got.images.push_back(m); });
  const CameraConfig config = loadCameraConfigPreset("omni_sim");
  SimCameraNode sim(camera_node, sim_bus, config, "msl");
  const Utime start = clock.now();
  // Each frame's scene, by frame number, taken when it was rendered.
  std::vector<SimScene> scenes;
  // 500 ms in steps of 1 ms (the frames' exposures fall between the states), SIM_WORLD every 10.
  for (int step = 0; step < 500; ++step) {
    if (step % 10 == 0) {
      world_state_t w = turningWorld(start, clock.now());
      harness.publish(bus::channels::kSimWorld, w);
    }
    clock.advance(kMicrosPerMilli);
    camera_node.spinOnce(0);
    if (sim.framesRendered() > static_cast<std::int64_t>(scenes.size())) {
      scenes.push_back(sim.lastScene());
    }
    harness.spinOnce(0);
  }
  ASSERT_GE(got.images.size(), 12u);
  EXPECT_EQ(sim.framesExtrapolated(), 0);
  for (const image_t& img : got.images) {
    ASSERT_LT(static_cast<std::size_t>(img.frame_number), scenes.size());
    const SimScene& scene = scenes[static_cast<std::size_t>(img.frame_number)];
    // The states at the 10 ms steps before and after the exposure.
    const Utime t = img.header.utime;
    const Utime t0 = start + (t - start) / 10'000 * 10'000;
    ASSERT_LT(t0, t);  // strictly between: the test means interpolation
    const world_state_t before = turningWorld(start, t0);
    const world_state_t after = turningWorld(start, t0 + 10'000);
    const double f = static_cast<double>(t - t0) / 10'000.0;
    const double turn = geometry::angleDiff(after.robot_phi[0], before.robot_phi[0]);
    const double interpolated = before.robot_phi[0] + f * turn;
    // What it was before: `before` carried on with its turn rate (the mean of the 10 ms before).
    const double carried = before.robot_phi[0] + before.robot_omega[0] * (t - t0) * 1e-6;
    ASSERT_GT(std::abs(geometry::angleDiff(interpolated, carried)), 1e-4);
    EXPECT_NEAR(geometry::angleDiff(scene.robot.phi, interpolated), 0.0, 1e-6)
        << "frame " << img.frame_number << " at " << t - start;
    EXPECT_NEAR(scene.omega, after.robot_omega[0], 1e-9);
    EXPECT_NEAR(scene.robot.x, 1.0, 1e-12);
  }
}

TEST(SimCameraNode, WithoutALaterWorldStateCarriesTheNewestAndCountsIt) {
  SimulatedClock clock;
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera_node{{.process = "camera", .robot_id = 2, .status_period_us = 0}, clock, memq};
  const bus::BusId sim_bus = camera_node.addBus(memq);
  bus::Node harness{{.process = "harness", .robot_id = 0, .status_period_us = 0}, clock, memq};
  SimCameraNode sim(camera_node, sim_bus, loadCameraConfigPreset("omni_sim"), "msl");
  world_state_t w = makeWorld(clock.now());
  harness.publish(bus::channels::kSimWorld, w);  // then the simulator stalls
  for (int step = 0; step < 40; ++step) {        // 200 ms: 6 frames, none with a state after it
    clock.advance(5 * kMicrosPerMilli);
    camera_node.spinOnce(0);
  }
  EXPECT_GE(sim.framesRendered(), 5);
  EXPECT_EQ(sim.framesExtrapolated(), sim.framesRendered());
  EXPECT_EQ(camera_node.status().errorCount("stale_world"), 0);
}

TEST(SimCameraNode, PublishesRenderedFramesAfterTheLatencyStampedWithTheExposure) {
  SimulatedClock clock;
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera_node{{.process = "camera", .robot_id = 2, .status_period_us = 0}, clock, memq};
  const bus::BusId sim_bus = camera_node.addBus(memq);
  bus::Node harness{{.process = "harness", .robot_id = 0, .status_period_us = 0}, clock, memq};
  Received got;
  harness.subscribe(bus::channels::kCameraImage,
                    [&](const image_t& m) { got.images.push_back(m); });

  const CameraConfig config = loadCameraConfigPreset("omni_sim");
  SimCameraNode sim(camera_node, sim_bus, config, "msl");
  const Utime start = clock.now();
  for (int step = 0; step < 100; ++step) {  // 500 ms in steps of 5 ms
    if (step % 2 == 0) {
      world_state_t w = makeWorld(clock.now());
      harness.publish(bus::channels::kSimWorld, w);
    }
    clock.advance(5 * kMicrosPerMilli);
    camera_node.spinOnce(0);
    harness.spinOnce(0);
  }
  // Frames exposed at 33, 67, ... ms; those exposed by 440 ms are published by 500 ms.
  ASSERT_GE(got.images.size(), 12u);
  ASSERT_LE(got.images.size(), 14u);
  EXPECT_EQ(sim.framesPublished(), static_cast<std::int64_t>(got.images.size()));
  const ColourTable colours = loadColourTablePreset(config.model.colour_table);
  for (std::size_t k = 0; k < got.images.size(); ++k) {
    const image_t& img = got.images[k];
    EXPECT_EQ(img.width, 320);
    EXPECT_EQ(img.height, 240);
    EXPECT_EQ(img.format, image_t::FORMAT_YUYV);
    EXPECT_EQ(img.source, image_t::SOURCE_SIM);
    EXPECT_EQ(img.frame_number, static_cast<std::int64_t>(k));
    EXPECT_EQ(img.header.robot_id, 2);
    // Latency: 60 ms, late by at most one 5 ms step of this loop.
    const Utime latency = img.header.utime_published - img.header.utime;
    EXPECT_GE(latency, 60 * kMicrosPerMilli);
    EXPECT_LE(latency, 65 * kMicrosPerMilli);
    if (k > 0) {
      EXPECT_NEAR(static_cast<double>(img.header.utime - got.images[k - 1].header.utime), 33333.0,
                  5000.0);
    }
    // The ball appears where robot 2, at its pose at the exposure time, expects it.
    const double dt = static_cast<double>(img.header.utime - start) * 1e-6;
    ASSERT_LT(dt, 1.0);
    SimScene scene;
    ASSERT_TRUE(sceneFromWorld(makeWorld(img.header.utime), 2, img.header.utime, 0.008, scene));
    const Vec2 ball = geometry::pointFieldToRobot(scene.robot, scene.ball->position);
    const Vec2 px = *config.model.mirror.robotPointToImage(Vec3(ball.x(), ball.y(), 0.11));
    const FrameView view = *msg::fromMessage(img);
    EXPECT_EQ(colours.classifyPixel(view, static_cast<int>(std::lround(px.x())),
                                    static_cast<int>(std::lround(px.y()))),
              ColourClass::kOrange);
  }
}

TEST(SimCameraNode, OnARobotClockRendersTheTruthOfTheExposure) {
  // Robot 2's clock runs 0.7 s behind the simulator's truth (more than the 0.5 s a world state may
  // be away from the exposure) and 30 ppm fast: frames are stamped
  // on the robot's clock, and show the world at the true time of their exposure.
  SimulatedClock truth;
  OffsetClock robot_clock(truth, -700'000, 30.0, truth.now());
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera_node{
      {.process = "camera", .robot_id = 2, .status_period_us = 0}, robot_clock, memq};
  const bus::BusId sim_bus = camera_node.addBus(memq);
  bus::Node harness{{.process = "harness", .robot_id = 0, .status_period_us = 0}, truth, memq};
  Received got;
  harness.subscribe(bus::channels::kCameraImage,
                    [&](const image_t& m) { got.images.push_back(m); });
  const CameraConfig config = loadCameraConfigPreset("omni_sim");
  SimCameraNode sim(camera_node, sim_bus, config, "msl");
  for (int step = 0; step < 100; ++step) {
    if (step % 2 == 0) {
      world_state_t w = makeWorld(truth.now());
      harness.publish(bus::channels::kSimWorld, w);
    }
    truth.advance(5 * kMicrosPerMilli);
    camera_node.spinOnce(0);
    harness.spinOnce(0);
  }
  EXPECT_EQ(camera_node.status().errorCount("stale_world"), 0);
  ASSERT_GE(got.images.size(), 12u);
  const ColourTable colours = loadColourTablePreset(config.model.colour_table);
  for (const image_t& img : got.images) {
    const Utime exposure_truth = robot_clock.toTruth(img.header.utime);
    EXPECT_NEAR(static_cast<double>(img.header.utime - exposure_truth), -700'000.0, 100.0);
    SimScene scene;
    ASSERT_TRUE(sceneFromWorld(makeWorld(exposure_truth), 2, exposure_truth, 0.008, scene));
    const Vec2 ball = geometry::pointFieldToRobot(scene.robot, scene.ball->position);
    const Vec2 px = *config.model.mirror.robotPointToImage(Vec3(ball.x(), ball.y(), 0.11));
    const FrameView view = *msg::fromMessage(img);
    EXPECT_EQ(colours.classifyPixel(view, static_cast<int>(std::lround(px.x())),
                                    static_cast<int>(std::lround(px.y()))),
              ColourClass::kOrange);
  }
}

TEST(SimCameraNode, StaleOrMissingRobotIsCountedNotRendered) {
  SimulatedClock clock;
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera_node{{.process = "camera", .robot_id = 4, .status_period_us = 0}, clock, memq};
  const bus::BusId sim_bus = camera_node.addBus(memq);
  bus::Node harness{{.process = "harness", .robot_id = 0, .status_period_us = 0}, clock, memq};
  SimCameraNode sim(camera_node, sim_bus, loadCameraConfigPreset("omni_sim"), "msl");
  world_state_t w = makeWorld(clock.now());
  harness.publish(bus::channels::kSimWorld, w);  // robot 4 is not in it
  for (int step = 0; step < 20; ++step) {
    clock.advance(5 * kMicrosPerMilli);
    camera_node.spinOnce(0);
  }
  EXPECT_GT(camera_node.status().errorCount("no_pose"), 0);
  w = makeWorld(clock.now());
  w.robot_id = {4, 5};
  harness.publish(bus::channels::kSimWorld, w);
  camera_node.spinOnce(0);
  clock.advance(kMicrosPerSecond);  // the world state is now a second old
  for (int step = 0; step < 20; ++step) {
    clock.advance(5 * kMicrosPerMilli);
    camera_node.spinOnce(0);
  }
  EXPECT_GT(camera_node.status().errorCount("stale_world"), 0);
  EXPECT_EQ(sim.framesRendered(), 0);
}

TEST(RunFrameSource, StampsReceiveTimeMinusLatencyAndKeepsSizeAndFormat) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "fieldline_camera_node_folder";
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(cv::imwrite((dir / ("f" + std::to_string(k) + ".png")).string(),
                            cv::Mat(50 + k, 70, CV_8UC3, cv::Scalar(10 * k, 20, 30))));
  }
  SimulatedClock clock;
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera_node{{.process = "camera", .robot_id = 1, .status_period_us = 0}, clock, memq};
  bus::Node harness{{.process = "harness", .robot_id = 1, .status_period_us = 0}, clock, memq};
  std::vector<image_t> got;
  harness.subscribe(bus::channels::kCameraImage, [&](const image_t& m) { got.push_back(m); });
  ImageFolderSource source(dir.string(), false);
  PipelineParams pipeline;
  pipeline.latency = 0.1;
  EXPECT_EQ(runFrameSource(camera_node, source, pipeline, {}), 3);
  harness.spinOnce(0);
  ASSERT_EQ(got.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(got[k].header.utime, clock.now() - 100'000);
    EXPECT_EQ(got[k].width, 70);
    EXPECT_EQ(got[k].height, 50 + k);
    EXPECT_EQ(got[k].format, image_t::FORMAT_BGR);
    EXPECT_EQ(got[k].source, image_t::SOURCE_FOLDER);
    EXPECT_EQ(got[k].data[0], 10 * k);  // blue of the first pixel
  }
  fs::remove_all(dir);
}

TEST(LogImageSource, ReadsValidCameraFramesAndCountsTheRest) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "fieldline_camera_test.lcmlog").string();
  {
    bus::LogWriter log(path);
    for (int k = 0; k < 4; ++k) {
      image_t img{};  // value-initialised: a stack-garbage robot_id made the reader refuse it
      img.header.utime = 1000 + k;
      img.width = 4;
      img.height = 2;
      img.stride = 8;
      img.format = image_t::FORMAT_YUYV;
      img.source = image_t::SOURCE_SIM;
      img.frame_number = k;
      img.size = 16;
      img.data.assign(16, static_cast<std::uint8_t>(50 + k));
      if (k == 2) {
        // Frame 2 claims three rows of 8 bytes but holds two: invalid, skipped and counted.
        std::vector<std::uint8_t> bytes(static_cast<std::size_t>(img.getEncodedSize()));
        img.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        // height is the second int32 after the 8-byte fingerprint and the 33-byte header.
        bytes[8 + 33 + 4 + 3] = 3;
        log.write(bus::channels::kCameraImage.name, 1000 + k, bytes.data(),
                  static_cast<int>(bytes.size()));
      } else {
        log.write(bus::channels::kCameraImage, 1000 + k, img);
      }
      odometry_t odo{};
      odo.header.utime = 1000 + k;
      log.write(bus::channels::kOdometry, 1000 + k, odo);
    }
  }
  LogImageSource source(path, false);
  SourceFrame frame;
  for (int k : {0, 1, 3}) {
    ASSERT_TRUE(source.next(frame)) << "frame " << k << ": " << source.lastError();
    EXPECT_EQ(frame.width, 4);
    EXPECT_EQ(frame.format, PixelFormat::kYuyv);
    EXPECT_EQ(frame.bytes[0], 50 + k);
  }
  EXPECT_EQ(frame.frame_number, 2);  // the source's count of delivered frames
  EXPECT_FALSE(source.next(frame));
  EXPECT_EQ(source.errors(), 1);
  EXPECT_NE(source.lastError().find("invalid"), std::string::npos) << source.lastError();

  // Looping starts again at the first frame.
  LogImageSource looping(path, true);
  for (int k = 0; k < 4; ++k)
    ASSERT_TRUE(looping.next(frame)) << k;
  EXPECT_EQ(frame.bytes[0], 50);
  std::filesystem::remove(path);
}

}  // namespace camera_node_test
}  // namespace fieldline::camera
