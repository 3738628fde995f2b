// The pilot: no command without a fresh pose, trajectory clock from the first pose, and closed
// loop against the simulated world it drives the robot along its path.
#include <gtest/gtest.h>

#include "services/pilot/pilot.hpp"
#include "services/world_sim/world.hpp"

namespace fieldline::pilot {
namespace pilot_test {

constexpr Utime kT0 = 1'700'000'000'000'000;

TEST(Pilot, NeedsAFreshPose) {
  const auto scenario = scenario::loadScenarioPreset("default");
  const auto params = robot::loadRobotPreset("fu2004");
  EXPECT_THROW(Pilot(scenario, 9, params), std::invalid_argument);
  Pilot pilot(scenario, 3, params);  // rotates in place at 1 rad/s
  EXPECT_FALSE(pilot.command(kT0).has_value());
  pilot.onPose(scenario.robotById(3)->start, kT0);
  const auto cmd = pilot.command(kT0);
  ASSERT_TRUE(cmd.has_value());
  EXPECT_NEAR(cmd->omega, 1.0 / params.max_omega, 1e-12);
  EXPECT_NEAR(cmd->vx, 0.0, 1e-12);
  // 0.4 s later without a new pose: silence.
  EXPECT_FALSE(pilot.command(kT0 + 400'000).has_value());
  // NaN poses are ignored.
  pilot.onPose({std::nan(""), 0.0, 0.0}, kT0 + 400'000);
  EXPECT_FALSE(pilot.command(kT0 + 400'000).has_value());
}

// Fusion publishes a second state with the same stamp right after a camera frame corrected it:
// the pilot takes that one; an older stamp is late and ignored.
TEST(Pilot, TakesTheCorrectedStateOfTheSameStampButNotALateOne) {
  const auto scenario = scenario::loadScenarioPreset("default");
  Pilot pilot(scenario, 3, robot::loadRobotPreset("fu2004"));
  const auto start = scenario.robotById(3)->start;
  pilot.onPose(start, kT0);
  ASSERT_TRUE(pilot.command(kT0).has_value());
  pilot.onPose(start, kT0, PoseQuality::kUnusable, "SEARCHING");
  EXPECT_FALSE(pilot.command(kT0).has_value());
  pilot.onPose(start, kT0 - 20'000, PoseQuality::kUsable);
  EXPECT_FALSE(pilot.command(kT0).has_value());
}

TEST(Pilot, DrivesTheWorldAlongItsTrajectory) {
  auto scenario = scenario::loadScenarioPreset("default");
  // Start on the tour (its last corner), so the worst error measures following, not the approach
  // from the kick-off position.
  for (auto& robot : scenario.robots) {
    if (robot.id == 2) robot.start = {2.0, 3.0, 0.0};
  }
  world_sim::World world(scenario);
  Pilot pilot(scenario, 2, world.robotParams());  // the waypoint tour at 1.2 m/s
  const int index = world.indexOf(2);
  double worst = 0.0;
  for (int sample = 0; sample < 50 * 30; ++sample) {
    const Utime now = kT0 + static_cast<Utime>(world.time() * 1e6);
    pilot.onPose(world.robots()[index].pose, now);
    world.setCommand(static_cast<std::size_t>(index), *pilot.command(now));
    for (int k = 0; k < 8; ++k)
      world.step();
    const auto ref = pilot.reference(kT0 + static_cast<Utime>(world.time() * 1e6));
    if (world.time() > 2.0) {
      worst =
          std::max(worst, (ref->pose.position() - world.robots()[index].pose.position()).norm());
    }
  }
  // Corners of the tour are cut a little; otherwise it stays on the path.
  EXPECT_LT(worst, 0.35);
}

}  // namespace pilot_test
}  // namespace fieldline::pilot
