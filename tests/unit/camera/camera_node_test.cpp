// The camera node over memq:// with a simulated clock (and robot clocks ahead of it or behind it):
// SIM_WORLD in, CAMERA_IMAGE out with the exposure time as utime and the configured latency, its
// pixels those of a second renderer's for the interpolated scene; real sources re-stamped on
// receipt; the LCM log reader.
#include "services/camera/camera_node.hpp"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/camera/colour.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/msg/image.hpp"
#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"
#include "services/camera/log_source.hpp"

namespace fieldline::camera {
namespace camera_node_test {

// Every field set: a world_state_t's numbers are not initialised by its constructor (lcm-gen), and
// robot_radius left to the stack's garbage made the teammate's size differ between a state the
// harness published and the same state built again in the test.
world_state_t makeWorld(Utime utime) {
  world_state_t w{};
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
  w.robot_radius = 0.25f;
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

// A camera node of one robot and a harness (the simulator's side, on the true time) on one
// memq:// bus; the harness keeps every CAMERA_IMAGE it gets.
class SimCameraNodeTest : public ::testing::Test {
 protected:
  SimCameraNodeTest() {
    harness.subscribe(bus::channels::kCameraImage,
                      [this](const image_t& m) { images.push_back(m); });
  }

  // The camera of robot `robot_id` on `camera_clock` (the simulator's true time by default).
  SimCameraNode& startCamera(int robot_id = 2, const Clock* camera_clock = nullptr) {
    camera_node.emplace(
        bus::NodeOptions{.process = "camera", .robot_id = robot_id, .status_period_us = 0},
        camera_clock != nullptr ? *camera_clock : clock, memq);
    const bus::BusId sim_bus = camera_node->addBus(memq);
    sim = std::make_unique<SimCameraNode>(*camera_node, sim_bus, config, "msl");
    return *sim;
  }
  // SIM_WORLD from the simulator.
  void publishWorld(world_state_t w) { harness.publish(bus::channels::kSimWorld, w); }
  // `dt` of true time on, then the camera's round and (with `deliver`) the harness'.
  void step(Utime dt, bool deliver = true) {
    clock.advance(dt);
    camera_node->spinOnce(0);
    if (deliver) harness.spinOnce(0);
  }

  // The turning robot (turningWorld from now) for `ms` milliseconds in steps of 1 ms (the frames'
  // exposures fall between the states), SIM_WORLD every 10; returns each frame's scene, by frame
  // number, taken when it was rendered.
  std::vector<SimScene> runTurningRobot(int ms) {
    const Utime start = clock.now();
    std::vector<SimScene> scenes;
    for (int step_ms = 0; step_ms < ms; ++step_ms) {
      if (step_ms % 10 == 0) publishWorld(turningWorld(start, clock.now()));
      clock.advance(kMicrosPerMilli);
      camera_node->spinOnce(0);
      if (sim->framesRendered() > static_cast<std::int64_t>(scenes.size())) {
        scenes.push_back(sim->lastScene());
      }
      harness.spinOnce(0);
    }
    return scenes;
  }

  // The ball's pixel in a frame is orange where robot 2 at `world`'s pose expects it.
  void expectBallWhereTheRobotSeesIt(const image_t& img, const world_state_t& world, Utime when) {
    SimScene scene;
    ASSERT_TRUE(sceneFromWorld(world, 2, when, 0.008, scene));
    const Vec2 ball = geometry::pointFieldToRobot(scene.robot, scene.ball->position);
    const Vec2 px = *config.model.mirror.robotPointToImage(Vec3(ball.x(), ball.y(), 0.11));
    const FrameView view = *msg::fromMessage(img);
    EXPECT_EQ(colours.classifyPixel(view, static_cast<int>(std::lround(px.x())),
                                    static_cast<int>(std::lround(px.y()))),
              ColourClass::kOrange);
  }

  // A frame of the turning robot (turningWorld from `start`) exposed at true time `t`: its scene
  // (the node's, when it rendered it) is the heading interpolated between the states at the 10 ms
  // steps around `t`, and its pixels are those a second renderer draws of that scene.
  void expectInterpolatedFrame(Utime start, Utime t, const image_t& img, const SimScene& scene) {
    const Utime t0 = start + (t - start) / 10'000 * 10'000;
    const world_state_t before = turningWorld(start, t0);
    const world_state_t after = turningWorld(start, t0 + 10'000);
    SimScene expected;
    ASSERT_EQ(sceneBetweenWorlds(before, after, 2, t, config.pipeline.exposure, expected),
              ScenePose::kInterpolated);
    const double f = static_cast<double>(t - t0) / 10'000.0;
    const double turn = geometry::angleDiff(after.robot_phi[0], before.robot_phi[0]);
    EXPECT_NEAR(geometry::angleDiff(scene.robot.phi, before.robot_phi[0] + f * turn), 0.0, 1e-6)
        << "frame " << img.frame_number << " at " << t - start;
    EXPECT_NEAR(scene.omega, after.robot_omega[0], 1e-9);
    EXPECT_NEAR(scene.robot.x, 1.0, 1e-12);
    if (!twin) twin.emplace(config.model.mirror, field::loadFieldPreset("msl"), *config.render);
    expected.frame_number = static_cast<std::uint64_t>(img.frame_number);
    twin->render(expected, twin_bytes);
    ASSERT_EQ(twin_bytes.size(), img.data.size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < twin_bytes.size(); ++i)
      differ += twin_bytes[i] != img.data[i] ? 1 : 0;
    EXPECT_EQ(differ, 0u) << "bytes of frame " << img.frame_number;
  }

  SimulatedClock clock;  // the simulator's true time
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node harness{{.process = "harness", .robot_id = 0, .status_period_us = 0}, clock, memq};
  const CameraConfig config = loadCameraConfigPreset("omni_sim");
  const ColourTable colours = loadColourTablePreset(config.model.colour_table);
  // A robot clock the node reads, declared before the node so that it outlives it.
  std::optional<OffsetClock> robot_clock;
  std::optional<bus::Node> camera_node;
  std::unique_ptr<SimCameraNode> sim;
  std::vector<image_t> images;
  std::optional<SimRenderer> twin;
  std::vector<std::uint8_t> twin_bytes;
};

TEST_F(SimCameraNodeTest, RendersEachFrameBetweenTheWorldStatesAroundItsExposure) {
  startCamera();
  const Utime start = clock.now();
  const std::vector<SimScene> scenes = runTurningRobot(500);
  ASSERT_GE(images.size(), 12u);
  EXPECT_EQ(sim->framesExtrapolated(), 0);
  for (const image_t& img : images) {
    ASSERT_LT(static_cast<std::size_t>(img.frame_number), scenes.size());
    const SimScene& scene = scenes[static_cast<std::size_t>(img.frame_number)];
    // The states at the 10 ms steps before and after the exposure.
    const Utime t = img.header.utime;
    const Utime t0 = start + (t - start) / 10'000 * 10'000;
    ASSERT_LT(t0, t);  // strictly between: the test means interpolation
    const world_state_t before = turningWorld(start, t0);
    const double f = static_cast<double>(t - t0) / 10'000.0;
    const double turn =
        geometry::angleDiff(turningWorld(start, t0 + 10'000).robot_phi[0], before.robot_phi[0]);
    // What it was before: `before` carried on with its turn rate (the mean of the 10 ms before).
    const double carried = before.robot_phi[0] + before.robot_omega[0] * (t - t0) * 1e-6;
    ASSERT_GT(std::abs(geometry::angleDiff(before.robot_phi[0] + f * turn, carried)), 1e-4);
    expectInterpolatedFrame(start, t, img, scene);
  }
}

// The robot's clock ahead of the simulator's truth or behind it, and running fast or slow: the
// frames are stamped with the exposure on the robot's clock, delivered the latency later on it,
// and show the world interpolated at the exposure's true time (its pixels those of that scene).
class SimCameraNodeOffsetTest : public SimCameraNodeTest,
                                public ::testing::WithParamInterface<ClockError> {};

TEST_P(SimCameraNodeOffsetTest, StampsOnTheRobotClockAndInterpolatesAtTheTrueExposure) {
  const ClockError error{GetParam().offset_us, GetParam().drift_ppm, clock.now()};
  robot_clock.emplace(clock, error);
  startCamera(2, &*robot_clock);
  const Utime start = clock.now();
  const std::vector<SimScene> scenes = runTurningRobot(400);
  EXPECT_EQ(camera_node->status().errorCount("stale_world"), 0);
  EXPECT_EQ(sim->framesExtrapolated(), 0);
  ASSERT_GE(images.size(), 9u);
  for (std::size_t k = 0; k < images.size(); ++k) {
    const image_t& img = images[k];
    const Utime exposure_truth = robot_clock->toTruth(img.header.utime);
    // The stamp is the robot clock's reading at the exposure (to its rounding).
    EXPECT_NEAR(static_cast<double>(img.header.utime - truthToOwn(error, exposure_truth)), 0.0,
                1.0);
    EXPECT_NEAR(static_cast<double>(img.header.utime - exposure_truth),
                static_cast<double>(error.offset_us), 2.0 + std::abs(error.drift_ppm));
    // Published the latency (60 ms of elapsed time) after the exposure, within one 1 ms step: on
    // the robot clock 60 ms give or take its drift (and a µs of rounding each stamp).
    const double drift = std::abs(error.drift_ppm) * 1e-6;
    const auto latency = static_cast<double>(img.header.utime_published - img.header.utime);
    EXPECT_GE(latency, 60'000.0 * (1.0 - drift) - 2.0);
    EXPECT_LE(latency, 61'000.0 * (1.0 + drift) + 2.0);
    if (k > 0) {
      EXPECT_NEAR(static_cast<double>(img.header.utime - images[k - 1].header.utime), 33333.0,
                  1001.0);
    }
    ASSERT_LT(static_cast<std::size_t>(img.frame_number), scenes.size());
    expectInterpolatedFrame(start, exposure_truth, img,
                            scenes[static_cast<std::size_t>(img.frame_number)]);
  }
}

INSTANTIATE_TEST_SUITE_P(AheadAndBehind, SimCameraNodeOffsetTest,
                         ::testing::Values(ClockError{400'000, 50.0, 0},
                                           ClockError{-700'000, -30.0, 0},
                                           ClockError{3'000, 0.0, 0}),
                         [](const ::testing::TestParamInfo<ClockError>& info) {
                           return std::string(info.param.offset_us < 0 ? "Behind" : "Ahead") +
                                  std::to_string(std::abs(info.param.offset_us)) + "us";
                         });

TEST_F(SimCameraNodeTest, WithoutALaterWorldStateCarriesTheNewestAndCountsIt) {
  startCamera();
  publishWorld(makeWorld(clock.now()));  // then the simulator stalls
  for (int k = 0; k < 40; ++k)           // 200 ms: 6 frames, none with a state after it
    step(5 * kMicrosPerMilli, false);
  EXPECT_GE(sim->framesRendered(), 5);
  EXPECT_EQ(sim->framesExtrapolated(), sim->framesRendered());
  EXPECT_EQ(camera_node->status().errorCount("stale_world"), 0);
}

TEST_F(SimCameraNodeTest, PublishesRenderedFramesAfterTheLatencyStampedWithTheExposure) {
  startCamera();
  const Utime start = clock.now();
  for (int k = 0; k < 100; ++k) {  // 500 ms in steps of 5 ms
    if (k % 2 == 0) publishWorld(makeWorld(clock.now()));
    step(5 * kMicrosPerMilli);
  }
  // Frames exposed at 33, 67, ... ms; those exposed by 440 ms are published by 500 ms.
  ASSERT_GE(images.size(), 12u);
  ASSERT_LE(images.size(), 14u);
  EXPECT_EQ(sim->framesPublished(), static_cast<std::int64_t>(images.size()));
  for (std::size_t k = 0; k < images.size(); ++k) {
    const image_t& img = images[k];
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
      EXPECT_NEAR(static_cast<double>(img.header.utime - images[k - 1].header.utime), 33333.0,
                  5000.0);
    }
    // The ball appears where robot 2, at its pose at the exposure time, expects it.
    ASSERT_LT(static_cast<double>(img.header.utime - start) * 1e-6, 1.0);
    expectBallWhereTheRobotSeesIt(img, makeWorld(img.header.utime), img.header.utime);
  }
}

TEST_F(SimCameraNodeTest, OnARobotClockRendersTheTruthOfTheExposure) {
  // Robot 2's clock runs 0.7 s behind the simulator's truth (more than the 0.5 s a world state may
  // be away from the exposure) and 30 ppm fast: frames are stamped
  // on the robot's clock, and show the world at the true time of their exposure.
  robot_clock.emplace(clock, -700'000, 30.0, clock.now());
  startCamera(2, &*robot_clock);
  for (int k = 0; k < 100; ++k) {
    if (k % 2 == 0) publishWorld(makeWorld(clock.now()));
    step(5 * kMicrosPerMilli);
  }
  EXPECT_EQ(camera_node->status().errorCount("stale_world"), 0);
  ASSERT_GE(images.size(), 12u);
  for (const image_t& img : images) {
    const Utime exposure_truth = robot_clock->toTruth(img.header.utime);
    EXPECT_NEAR(static_cast<double>(img.header.utime - exposure_truth), -700'000.0, 100.0);
    expectBallWhereTheRobotSeesIt(img, makeWorld(exposure_truth), exposure_truth);
  }
}

TEST_F(SimCameraNodeTest, StaleOrMissingRobotIsCountedNotRendered) {
  startCamera(4);
  world_state_t w = makeWorld(clock.now());
  publishWorld(w);  // robot 4 is not in it
  for (int k = 0; k < 20; ++k)
    step(5 * kMicrosPerMilli, false);
  EXPECT_GT(camera_node->status().errorCount("no_pose"), 0);
  w = makeWorld(clock.now());
  w.robot_id = {4, 5};
  publishWorld(w);
  camera_node->spinOnce(0);
  clock.advance(kMicrosPerSecond);  // the world state is now a second old
  for (int k = 0; k < 20; ++k)
    step(5 * kMicrosPerMilli, false);
  EXPECT_GT(camera_node->status().errorCount("stale_world"), 0);
  EXPECT_EQ(sim->framesRendered(), 0);
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
