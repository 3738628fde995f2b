// SIM_WORLD's conversion (common/msg/world_state): round trip of the truth, lookup by robot
// number, and arrays shorter than their counts never read past their end.
#include <gtest/gtest.h>

#include "common/msg/world_state.hpp"

namespace fieldline::msg {
namespace world_state_msg_test {

perception::WorldTruth sampleTruth() {
  perception::WorldTruth w;
  w.utime = 1'800'000'000'000'000;
  w.field = "msl";
  w.scenario = "default";
  w.robot_radius = 0.25;
  w.robots.push_back({.id = 2, .pose = {1.0, -2.0, 0.5}, .velocity = {0.1, 0.2}, .omega = 0.3});
  w.robots.push_back({.id = 5, .pose = {-3.0, 1.5, -1.0}, .kidnaps = 2});
  w.opponents.push_back({.pose = {4.0, 0.0, 3.0}, .radius = 0.3});
  w.ball = {.position = {0.5, 0.25}, .velocity = {-1.0, 0.0}, .radius = 0.11};
  return w;
}

TEST(WorldStateMsg, RoundTripKeepsTheTruth) {
  world_state_t m{};
  toMessage(sampleTruth(), m);
  EXPECT_EQ(m.num_robots, 2);
  EXPECT_EQ(m.num_opponents, 1);
  const auto w = fromMessage(m);
  EXPECT_EQ(w.utime, 1'800'000'000'000'000);
  EXPECT_EQ(w.field, "msl");
  EXPECT_EQ(w.scenario, "default");
  EXPECT_FLOAT_EQ(static_cast<float>(w.robot_radius), 0.25f);
  ASSERT_EQ(w.robots.size(), 2u);
  const auto* two = w.robot(2);
  ASSERT_NE(two, nullptr);
  EXPECT_DOUBLE_EQ(two->pose.x, 1.0);
  EXPECT_DOUBLE_EQ(two->pose.y, -2.0);
  EXPECT_DOUBLE_EQ(two->pose.phi, 0.5);
  EXPECT_DOUBLE_EQ(two->velocity.y(), 0.2);
  EXPECT_DOUBLE_EQ(two->omega, 0.3);
  EXPECT_EQ(w.robot(5)->kidnaps, 2);
  EXPECT_EQ(w.robot(3), nullptr);
  ASSERT_EQ(w.opponents.size(), 1u);
  EXPECT_DOUBLE_EQ(w.opponents[0].pose.phi, 3.0);
  EXPECT_FLOAT_EQ(static_cast<float>(w.opponents[0].radius), 0.3f);
  EXPECT_DOUBLE_EQ(w.ball.position.x(), 0.5);
  EXPECT_DOUBLE_EQ(w.ball.velocity.x(), -1.0);

  // Reusing the message for a smaller world leaves nothing of the bigger one.
  auto smaller = sampleTruth();
  smaller.robots.pop_back();
  smaller.opponents.clear();
  toMessage(smaller, m);
  EXPECT_EQ(m.robot_x.size(), 1u);
  EXPECT_EQ(fromMessage(m).robots.size(), 1u);
  EXPECT_TRUE(fromMessage(m).opponents.empty());
}

TEST(WorldStateMsg, CountsBeyondTheArraysAreBounded) {
  world_state_t m{};
  toMessage(sampleTruth(), m);
  m.num_robots = 1000;
  m.robot_kidnaps.resize(1);
  m.num_opponents = -4;
  const auto w = fromMessage(m);
  EXPECT_EQ(w.robots.size(), 1u);
  EXPECT_TRUE(w.opponents.empty());
}

}  // namespace world_state_msg_test
}  // namespace fieldline::msg
