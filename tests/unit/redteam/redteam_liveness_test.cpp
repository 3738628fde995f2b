// Issue 34, red-team finding 5: dead inputs still "ok". With the camera stopped for 20 s feature
// recognition said "ok 0.0 Hz" and fusion ok; with fusion stopped the pilot said "ok 7.9 Hz" while
// sending nothing. Each process whose input is dead or whose output is empty now says WARN with
// the channel. (Region tracking and fusion's ODOMETRY were already required: issue 13.)
//
// Run against main at 6957b54 (before the fix) each case failed: the state stayed ok.
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "common/field/field_model.hpp"
#include "common/robot/robot_params.hpp"
#include "common/scenario/scenario.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/camera_node.hpp"
#include "services/feature_recognition/feature_node.hpp"
#include "services/fusion/fusion_node.hpp"
#include "services/pilot/pilot_node.hpp"
#include "tests/unit/fusion/test_world.hpp"

namespace fieldline {
namespace redteam_liveness_test {

class redteam_dead_inputs : public ::testing::Test {
 protected:
  // Runs `seconds` in 20 ms steps, calling `each_step` and spinning every node; takes the status
  // of `watched` once a second as its timer would. Returns the last one.
  service_status_t run(double seconds, bus::Node& watched, const std::function<void()>& each_step) {
    service_status_t last{};
    for (int k = 1; k <= static_cast<int>(seconds * 50 + 0.5); ++k) {
      clock.advance(20'000);
      each_step();
      for (int i = 0; i < 3; ++i) {
        watched.spinOnce(0);
        source.spinOnce(0);
      }
      if (k % 50 == 0) last = watched.status().takeStatus(clock.now());
    }
    return last;
  }
  static bool says(const service_status_t& s, const std::string& what) {
    return s.state == service_status_t::STATE_WARN &&
           s.state_reason.find(what) != std::string::npos;
  }

  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node source{{.process = "source", .robot_id = 1, .status_period_us = 0}, clock, memq};
};

TEST_F(redteam_dead_inputs, FeatureRecognitionWithoutLines) {
  bus::Node node{
      {.process = "feature_recognition", .robot_id = 1, .status_period_us = 0}, clock, memq};
  const field::FieldModel field = field::loadFieldPreset("msl");
  feature_recognition::FeatureNode features(node, field);
  int k = 0;
  auto lines = [&] {
    if (++k % 3 != 0) return;  // 16.7 Hz
    line_contours_t m{};
    m.header.utime = clock.now();
    source.publish(bus::channels::kVisionLines, m);
  };
  EXPECT_EQ(run(3.0, node, lines).state, service_status_t::STATE_OK);
  const service_status_t s = run(4.0, node, [] {});  // the camera stopped
  EXPECT_TRUE(says(s, "VISION_LINES silent")) << int(s.state) << " " << s.state_reason;
}

TEST_F(redteam_dead_inputs, FusionWithoutLines) {
  bus::Node node{{.process = "fusion", .robot_id = 1, .status_period_us = 0}, clock, memq};
  fusion::FusionNodeOptions options;
  options.robot = robot::loadRobotPreset("fu2004");
  fusion::FusionNode fusion(node, options, fusion::test_support::world().functions());
  auto odometry = [&] {
    odometry_t m{};
    m.header.utime = clock.now() - 8'000;
    m.controller_utime = clock.now();
    source.publish(bus::channels::kOdometry, m);
  };
  const service_status_t s = run(4.0, node, odometry);
  EXPECT_TRUE(says(s, "VISION_LINES silent")) << int(s.state) << " " << s.state_reason;
}

TEST_F(redteam_dead_inputs, TheSimulatedCameraWithoutAWorld) {
  bus::Node node{{.process = "camera", .robot_id = 1, .status_period_us = 0}, clock, memq};
  camera::SimCameraNode camera(node, bus::kPrimaryBus, camera::loadCameraConfigPreset("omni_sim"),
                               "msl");
  const service_status_t s = run(4.0, node, [] {});  // no SIM_WORLD: no frames
  EXPECT_TRUE(says(s, "CAMERA_IMAGE silent")) << int(s.state) << " " << s.state_reason;
}

TEST_F(redteam_dead_inputs, APilotThatShouldDriveAndCannot) {
  bus::Node node{{.process = "pilot", .robot_id = 1, .status_period_us = 0}, clock, memq};
  const auto scenario = scenario::loadScenarioPreset("default");
  pilot::PilotNode pilot(node, pilot::Pilot(scenario, 1, robot::loadRobotPreset("fu2004")),
                         {.steer = pilot::SteerBy::kState});
  auto state = [&] {
    robot_state_t m{};
    m.header.utime = clock.now();
    m.x = -4.5;
    m.status = robot_state_t::STATUS_TRACKING;
    source.publish(bus::channels::kRobotState, m);
  };
  EXPECT_EQ(run(2.0, node, state).state, service_status_t::STATE_OK);
  const service_status_t s = run(4.0, node, [] {});  // fusion stopped
  EXPECT_TRUE(says(s, "ROBOT_STATE silent")) << int(s.state) << " " << s.state_reason;
  EXPECT_TRUE(says(s, "not driving its trajectory")) << s.state_reason;
}

}  // namespace redteam_liveness_test
}  // namespace fieldline
