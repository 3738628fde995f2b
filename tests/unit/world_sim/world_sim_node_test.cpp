// The world_sim node over memq:// with a simulated clock: the world follows the clock (never
// ahead of it), SIM_WORLD at the world rate stamped with simulated time, odometry frames on each
// robot's pseudo-terminal, and the scenario's serial outages (the line goes and comes back).
#include "services/world_sim/world_sim_node.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <span>
#include <vector>

#include <gtest/gtest.h>

#include "common/msg/world_state.hpp"
#include "common/serial/protocol.hpp"

namespace fieldline::world_sim {
namespace world_sim_node_test {

class WorldSimNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() /
          ("fieldline-world-sim-node-" + std::to_string(::getpid()));
    listener.subscribe(bus::channels::kSimWorld,
                       [this](const world_state_t& w) { states.push_back(msg::fromMessage(w)); });
  }
  void TearDown() override { std::filesystem::remove_all(dir); }

  // Moves the clock in 5 ms steps over `seconds`, the simulator and the listener handling
  // what is due after each.
  void run(double seconds) {
    for (int i = 0; i < static_cast<int>(seconds * 200 + 0.5); ++i) {
      clock.advance(5'000);
      sim_node.spinOnce(0);
      listener.spinOnce(0);
    }
  }

  std::filesystem::path dir;
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node sim_node{{.process = "world_sim", .robot_id = 0, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 0, .status_period_us = 0}, clock, memq};
  std::vector<perception::WorldTruth> states;
};

TEST_F(WorldSimNodeTest, PublishesTheWorldAtItsRateOnSimulatedTime) {
  const auto scenario = scenario::loadScenarioPreset("default");
  const Utime start = clock.now();
  WorldSimNode sim(sim_node, scenario, {.pty_dir = dir.string(), .world_rate = 100.0});
  run(0.2);
  // The state after the first step, then 100 Hz over 0.2 s (the last one may still be a step
  // short of the present).
  ASSERT_GE(states.size(), 20u);
  ASSERT_LE(states.size(), 21u);
  EXPECT_LE(sim.world().time(), 0.2 + 1e-9);
  EXPECT_GE(sim.world().time(), 0.2 - sim.world().stepSeconds() - 1e-9);
  EXPECT_EQ(states[0].utime, start + sim.utimeAt(sim.world().stepSeconds()) - sim.utimeAt(0.0));
  for (std::size_t k = 1; k < states.size(); ++k) {
    EXPECT_EQ(states[k].utime, start + static_cast<Utime>(k) * 10'000) << k;
    EXPECT_LE(states[k].utime, clock.now());
  }
  const auto& last = states.back();
  EXPECT_EQ(last.scenario, scenario.name);
  ASSERT_EQ(last.robots.size(), scenario.robots.size());
  const auto* three = last.robot(3);
  ASSERT_NE(three, nullptr);
  // Nobody drives it (no bridge): the robot stands where the scenario put it.
  EXPECT_NEAR(three->pose.x, scenario.robotById(3)->start.x, 1e-9);
  EXPECT_GT(last.robot_radius, 0.0);
}

TEST_F(WorldSimNodeTest, SendsOdometryOnThePtyAndPlaysTheOutages) {
  auto scenario = scenario::loadScenarioPreset("serial_test");
  scenario.serial_outages = {{.time = 0.1, .robot = 1, .duration = 0.1}};
  WorldSimNode sim(sim_node, scenario, {.pty_dir = dir.string()});
  ASSERT_EQ(sim.lines().size(), 1u);
  const std::string link = sim.lines().linkPath(0);

  // The bridge's side: the link opened as a device.
  int fd = ::open(link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  ASSERT_GE(fd, 0) << link;
  run(0.09);
  // The kernel hands bytes from the pty's master to its slave asynchronously (a work queue), so
  // one read may see only part of what was written: read until the line stays quiet.
  serial::Decoder decoder;
  std::vector<serial::Message> messages;
  std::vector<std::uint8_t> bytes(4096);
  pollfd waiting{.fd = fd, .events = POLLIN, .revents = 0};
  while (::poll(&waiting, 1, 200) > 0) {
    const ssize_t n = ::read(fd, bytes.data(), bytes.size());
    if (n <= 0) break;
    decoder.feed(std::span(bytes.data(), static_cast<std::size_t>(n)), messages);
  }
  ::close(fd);
  int samples = 0;
  for (const auto& m : messages)
    samples += std::holds_alternative<serial::OdometrySample>(m) ? 1 : 0;
  // Sampled at 20, 40, 60, 80 ms, each frame leaving the controller 8 ms later: four by 90 ms
  // (three when the last physics step falls just short).
  EXPECT_GE(samples, 3);
  EXPECT_LE(samples, 4);

  // The outage: the line is gone from 0.1 s to 0.2 s, then a new one is there.
  run(0.03);
  EXPECT_FALSE(sim.lines().isOpen(0));
  EXPECT_FALSE(std::filesystem::exists(link));
  run(0.1);
  EXPECT_TRUE(sim.lines().isOpen(0));
  EXPECT_TRUE(std::filesystem::exists(link));
}

// Issue 34 finding 3: ending the process at the scenario's end had the launcher restart the
// scenario at t = 0 (every robot jumping back); the world now goes on until it is stopped.
TEST_F(WorldSimNodeTest, TheWorldGoesOnAfterTheScenariosEnd) {
  auto scenario = scenario::loadScenarioPreset("serial_test");
  scenario.duration = 0.05;
  WorldSimNode sim(sim_node, scenario, {.pty_dir = dir.string()});
  run(0.1);
  EXPECT_TRUE(sim.finished());
  EXPECT_FALSE(sim_node.stopRequested());
  // Past the scenario's end, never ahead of the clock (the last step may still be due).
  EXPECT_GT(sim.world().time(), 0.1 - 1.5 * sim.world().stepSeconds());
  EXPECT_LE(sim.world().time(), 0.1 + 1e-9);
}

}  // namespace world_sim_node_test
}  // namespace fieldline::world_sim
