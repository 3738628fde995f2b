// Scenario files: the shipped ones load, mistakes are reported with file:line and key.
#include <string>

#include <gtest/gtest.h>

#include "common/scenario/scenario.hpp"

namespace fieldline::scenario {
namespace {

TEST(Scenario, ShippedScenariosLoad) {
  const auto d = loadScenarioPreset("default");
  EXPECT_EQ(d.robots.size(), 6u);
  EXPECT_EQ(d.opponents.size(), 4u);
  EXPECT_EQ(d.ball.kicks.size(), 3u);
  EXPECT_EQ(d.kidnaps.size(), 1u);
  ASSERT_NE(d.robotById(1), nullptr);
  EXPECT_TRUE(std::holds_alternative<robot::FigureEightSpec>(d.robotById(1)->trajectory));
  // The figure eight's start is its centre.
  EXPECT_NEAR(d.robotById(1)->start.x, -4.5, 1e-9);
  EXPECT_TRUE(std::holds_alternative<robot::RandomPlaySpec>(d.robotById(5)->trajectory));
  const auto f = loadScenarioPreset("figure_eight");
  EXPECT_DOUBLE_EQ(f.duration, 60.0);
  EXPECT_EQ(f.seed, 42u);
  const auto s = loadScenarioPreset("serial_test");
  EXPECT_DOUBLE_EQ(s.slip_scale, 0.0);
}

std::string errorOf(const std::string& yaml) {
  try {
    loadScenario(config::Node::loadString(yaml, "s.yaml"));
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(Scenario, MistakesNameFileLineAndKey) {
  const std::string head = "name: t\nseed: 1\n";
  EXPECT_NE(
      errorOf(head + "robots:\n  - id: 1\n    trajectory: {type: fly}\n    start: {x: 0, y: 0}\n")
          .find("'fly' is not one of"),
      std::string::npos);
  EXPECT_NE(
      errorOf(head + "robots:\n  - id: 7\n    trajectory: {type: stand}\n    start: {x: 0, y: 0}\n")
          .find("s.yaml:4: robots[0].id"),
      std::string::npos);
  EXPECT_NE(
      errorOf(head + "robots:\n  - id: 1\n    trajectory: {type: stand}\n").find("robots[0].start"),
      std::string::npos);
  EXPECT_NE(errorOf(head + "physics_rate: 50\nrobots:\n  - id: 1\n    trajectory: {type: stand}\n"
                           "    start: {x: 0, y: 0}\n")
                .find("physics_rate"),
            std::string::npos);
  EXPECT_NE(
      errorOf(head + "robots:\n  - id: 1\n    trajectory: {type: stand}\n    start: {x: 0, y: 0}\n"
                     "kidnaps:\n  - {time: 1, robot: 2, pose: {x: 0, y: 0}}\n")
          .find("no robot 2"),
      std::string::npos);
  EXPECT_NE(
      errorOf(head + "robots:\n  - id: 1\n    trajectory: {type: stand}\n    start: {x: 0, y: 0}\n"
                     "balll: {}\n")
          .find("balll: unknown key"),
      std::string::npos);
  EXPECT_EQ(errorOf(head +
                    "robots:\n  - id: 1\n    trajectory: {type: stand}\n    start: {x: 0, y: 0}\n"),
            "");
}

}  // namespace
}  // namespace fieldline::scenario
