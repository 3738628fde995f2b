// The colour adaptation in the tracking process (issue 12, part 2): with `adaptation.enabled`
// the node's table follows the light down to 0.4 of the calibration's along a drive, its status
// stays ok and reports the gain as `light_gain`; the same frames without adaptation (and without
// the line scan's ridge rule) leave the vision blind (WARN, no line points).
#include <string>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/msg/image.hpp"
#include "common/time/clock.hpp"
#include "services/region_tracking/tracking_node.hpp"
#include "tests/support/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace {

struct Outcome {
  service_status_t status;
  double light_gain = -1;
};

// Drives 240 frames: 30 in the calibration light, then the light falling linearly to x0.4.
Outcome driveIntoTheDark(bool adapt) {
  static SimCamera sim = SimCamera::load("omni_sim", "msl");
  SimulatedClock clock{1'800'000'000'000'000};
  auto memq = bus::Connection::open("memq://");
  bus::Node camera{{.process = "camera", .robot_id = 2, .status_period_us = 0}, clock, memq};
  bus::Node vision{
      {.process = "region_tracking", .robot_id = 2, .status_period_us = 0}, clock, memq};
  TrackingNodeOptions options;
  options.mirror = sim.mirror;
  options.colours = sim.table;
  options.adaptation.enabled = adapt;
  options.adaptation.min_gain = 0.3;
  // The colour classes alone: the line scan's ridge rule finds many dim lines without the
  // adaptation (docs/calibration.md, section 4), so without adaptation it is off here.
  if (!adapt) options.vision.lines.ridge_contrast = 0.0;
  TrackingNode tracking(vision, options);
  const int frames = 240;
  const auto poses = motionPoses(sim.field, Motion{.speed = 1.0, .omega = 0.5}, frames);
  service_status_t status;
  for (int frame = 0; frame < frames; ++frame) {
    camera::RealismParams light;
    light.light_factor = frame < 30 ? 1.0 : 1.0 - 0.6 * (frame - 30) / (frames - 31.0);
    sim.renderer->realism().setParams(light);
    clock.advance(33'333);
    camera::SimScene scene;
    scene.robot = poses[static_cast<std::size_t>(frame)];
    scene.frame_number = static_cast<std::uint64_t>(frame);
    sim.render(scene);
    image_t image{};
    image.header.utime = clock.now() - 60'000;
    msg::toMessage(sim.renderer->view(sim.frame), image);
    image.source = image_t::SOURCE_SIM;
    image.frame_number = frame;
    camera.publish(bus::channels::kCameraImage, image);
    vision.spinOnce(0);
    // The status of the last 45 frames (the dark end).
    if (frame == frames - 46) (void)vision.status().takeStatus(clock.now());
  }
  status = vision.status().takeStatus(clock.now());
  sim.renderer->realism().setParams({});
  Outcome out{status, -1};
  for (int i = 0; i < status.num_metrics; ++i) {
    if (status.metric_name[i] == "light_gain") out.light_gain = status.metric_value[i];
  }
  return out;
}

TEST(ColourAdaptationNode, TheTableFollowsTheLightAndTheVisionStaysHealthy) {
  const Outcome adapted = driveIntoTheDark(true);
  EXPECT_EQ(adapted.status.state, service_status_t::STATE_OK) << adapted.status.state_reason;
  EXPECT_GT(adapted.light_gain, 0.3);
  EXPECT_LT(adapted.light_gain, 0.6);

  const Outcome fixed = driveIntoTheDark(false);
  EXPECT_EQ(fixed.status.state, service_status_t::STATE_WARN);
  EXPECT_NE(fixed.status.state_reason.find("no line points"), std::string::npos)
      << fixed.status.state_reason;
  EXPECT_EQ(fixed.light_gain, -1);  // no such metric without adaptation
}

}  // namespace
}  // namespace fieldline::region_tracking
