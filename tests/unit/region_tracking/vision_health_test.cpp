// Vision health (issue 12, part 5): the region tracking status says WARN with the reason when
// the colour table does not fit the frames (the hall's light changed, the lens is covered, the
// colours are cast), and ok again when it fits. The node over memq:// with a simulated clock;
// the conditions one by one on the frame processor.
#include "services/region_tracking/vision_health.hpp"

#include <string>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/geometry/geometry.hpp"
#include "common/time/clock.hpp"
#include "services/region_tracking/tracking_node.hpp"
#include "tests/support/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace {

SimCamera& sharedCamera() {
  static SimCamera sim = SimCamera::load("omni_sim", "msl");
  return sim;
}

camera::RealismParams lightFactor(double f) {
  camera::RealismParams p;
  p.light_factor = f;
  return p;
}

TEST(VisionHealth, StatusWarnsWithTheReasonWhenTheTableDoesNotFitAndRecovers) {
  SimCamera& sim = sharedCamera();
  SimulatedClock clock{1'800'000'000'000'000};
  auto memq = bus::Connection::open("memq://");
  bus::Node camera{{.process = "camera", .robot_id = 3, .status_period_us = 0}, clock, memq};
  bus::Node vision{
      {.process = "region_tracking", .robot_id = 3, .status_period_us = 0}, clock, memq};
  TrackingNodeOptions options;
  options.mirror = sim.mirror;
  options.colours = sim.table;
  TrackingNode tracking(vision, options);

  const auto poses = motionPoses(sim.field, Motion{.speed = 1.0, .omega = 0.5}, 300);
  int frame = 0;
  // Renders and publishes `count` frames along the drive, lets the node process them and returns
  // the status of that stretch.
  auto drive = [&](int count) {
    for (int i = 0; i < count; ++i, ++frame) {
      clock.advance(33'333);
      camera::SimScene scene;
      scene.robot = poses[static_cast<std::size_t>(frame)];
      scene.frame_number = static_cast<std::uint64_t>(frame);
      image_t image = sim.renderImage(scene, clock.now() - 60'000);
      camera.publish(bus::channels::kCameraImage, image);
      vision.spinOnce(0);
    }
    return vision.status().takeStatus(clock.now());
  };

  sim.renderer->realism().setParams(lightFactor(1.0));
  const service_status_t fitting = drive(45);
  EXPECT_EQ(fitting.state, service_status_t::STATE_OK) << fitting.state_reason;
  EXPECT_EQ(tracking.healthReason(), "");

  // The hall at a third of the light the table was made for: the carpet is too dark for green.
  sim.renderer->realism().setParams(lightFactor(0.3));
  const service_status_t dark = drive(45);
  EXPECT_EQ(dark.state, service_status_t::STATE_WARN);
  EXPECT_NE(dark.state_reason.find("too little green"), std::string::npos) << dark.state_reason;
  EXPECT_NE(dark.state_reason.find("no line points"), std::string::npos) << dark.state_reason;
  EXPECT_NE(dark.state_reason.find("re-seeding green"), std::string::npos) << dark.state_reason;

  // The light is back: ok again.
  sim.renderer->realism().setParams(lightFactor(1.0));
  const service_status_t back = drive(60);
  EXPECT_EQ(back.state, service_status_t::STATE_OK) << back.state_reason;
  EXPECT_EQ(tracking.healthReason(), "");
  sim.renderer->realism().setParams({});
}

TEST(VisionHealth, NamesTheBallColourEverywhere) {
  SimCamera& sim = sharedCamera();
  FrameProcessor processor(sim.mirror, sim.table, defaultVisionParams());
  VisionHealth health(sim.mirror, sim.table, VisionHealthParams{});
  EXPECT_GT(health.samplePixels(), 500);
  camera::RealismParams cast;
  cast.chroma_shift = {0.0, 90.0};  // a red cast: the carpet turns orange
  sim.renderer->realism().setParams(cast);
  VisionResult result;
  camera::SimScene scene;
  scene.robot = {-1.0, 0.5, 0.2};
  for (int i = 0; i < 5; ++i) {
    scene.frame_number = static_cast<std::uint64_t>(i);
    const camera::FrameView view = sim.render(scene);
    processor.process(view, true, result);
    health.update(view, result);
  }
  sim.renderer->realism().setParams({});
  EXPECT_GT(health.orangeFraction(), 0.3);
  EXPECT_NE(health.reason().find("ball colour everywhere"), std::string::npos) << health.reason();

  // The same place in its own light: healthy, green over most of the floor.
  VisionHealth fresh(sim.mirror, sim.table, VisionHealthParams{});
  FrameProcessor clean(sim.mirror, sim.table, defaultVisionParams());
  for (int i = 0; i < 5; ++i) {
    scene.frame_number = static_cast<std::uint64_t>(i);
    const camera::FrameView view = sim.render(scene);
    clean.process(view, true, result);
    fresh.update(view, result);
  }
  EXPECT_TRUE(fresh.healthy()) << fresh.reason();
  EXPECT_GT(fresh.greenFraction(), 0.5);
  EXPECT_LT(fresh.orangeFraction(), 0.01);
}

TEST(VisionHealth, RefusesBadParameters) {
  SimCamera& sim = sharedCamera();
  VisionHealthParams p;
  p.window_frames = 0;
  EXPECT_THROW(VisionHealth(sim.mirror, sim.table, p), std::invalid_argument);
  EXPECT_THROW(loadVisionHealthParams(config::Node::loadString("window_frame: 3\n")),
               config::Error);
  EXPECT_EQ(loadVisionHealthParams(config::Node::loadString("window_frames: 3\n")).window_frames,
            3);
}

}  // namespace
}  // namespace fieldline::region_tracking
