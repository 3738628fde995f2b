// The colour adaptation in the tracking process (issue 12, part 2): with `adaptation.enabled`
// the node's table follows the light down to 0.4 of the calibration's along a drive, its status
// stays ok and reports the gain as `light_gain`; the same frames without adaptation (and without
// the line scan's ridge rule) leave the vision blind (WARN, no line points).
#include <algorithm>
#include <csignal>
#include <string>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/time/clock.hpp"
#include "services/region_tracking/tracking_node.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace {

struct Outcome {
  service_status_t status;
  double light_gain = -1;
  double colour_resets = -1;     // the metric; -1 when absent
  std::int64_t resets_done = 0;  // TrackingNode::colourResets()
};

// Drives 240 frames: 30 in the calibration light, then the light falling linearly to x0.4.
// With `resetAtEnd`, SIGUSR1 is raised after them (installColourResetSignal) and one more frame
// is sent; the status is then that frame's.
Outcome driveIntoTheDark(bool adapt, bool resetAtEnd = false) {
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
  const int sent = resetAtEnd ? frames + 1 : frames;
  for (int frame = 0; frame < sent; ++frame) {
    if (frame == frames) {
      (void)vision.status().takeStatus(clock.now());
      installColourResetSignal(tracking);
      std::raise(SIGUSR1);
    }
    camera::RealismParams light;
    light.light_factor =
        frame < 30 ? 1.0 : 1.0 - 0.6 * std::min(frame - 30, frames - 31) / (frames - 31.0);
    sim.renderer->realism().setParams(light);
    clock.advance(33'333);
    camera::SimScene scene;
    scene.robot = poses[static_cast<std::size_t>(std::min(frame, frames - 1))];
    scene.frame_number = static_cast<std::uint64_t>(frame);
    image_t image = sim.renderImage(scene, clock.now() - 60'000);
    camera.publish(bus::channels::kCameraImage, image);
    vision.spinOnce(0);
    // The status of the last 45 frames (the dark end).
    if (frame == frames - 46) (void)vision.status().takeStatus(clock.now());
  }
  status = vision.status().takeStatus(clock.now());
  sim.renderer->realism().setParams({});
  Outcome out{status, -1, -1, tracking.colourResets()};
  for (int i = 0; i < status.num_metrics; ++i) {
    if (status.metric_name[i] == "light_gain") out.light_gain = status.metric_value[i];
    if (status.metric_name[i] == "colour_resets") out.colour_resets = status.metric_value[i];
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

// Reset on demand, as a user triggers it on a running process (`kill -USR1 <pid>`): deep in the
// dark the table is adapted (gain about 0.45); after SIGUSR1 the next frame is classified with
// the calibrated table again (gain 1) and the reset is counted in the status.
TEST(ColourAdaptationNode, SigusrOneResetsTheAdaptationToTheCalibratedTable) {
  const Outcome reset = driveIntoTheDark(true, true);
  EXPECT_EQ(reset.resets_done, 1);
  EXPECT_EQ(reset.colour_resets, 1.0);
  EXPECT_EQ(reset.light_gain, 1.0);  // no reference given: the next 5 frames measure a new one

  // Without the adaptation there is nothing to reset: logged, not counted.
  const Outcome off = driveIntoTheDark(false, true);
  EXPECT_EQ(off.resets_done, 0);
  EXPECT_EQ(off.colour_resets, -1);
}

}  // namespace
}  // namespace fieldline::region_tracking
