// fieldline-launch --graph's joining of declarations (tools/launch/graph.hpp): writers are found
// on the reader's bus (its robot's, the simulator's, or every robot's for a monitor), and a
// required input without a writer is named.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tools/launch/graph.hpp"

namespace fieldline::launch {
namespace graph_test {

// The first line of `text` containing `part`, its runs of spaces made one.
std::string lineWith(const std::string& text, const std::string& part) {
  std::size_t from = 0;
  while (from < text.size()) {
    std::size_t end = text.find('\n', from);
    if (end == std::string::npos) end = text.size();
    std::string line;
    for (char c : text.substr(from, end - from)) {
      if (c != ' ' || (!line.empty() && line.back() != ' ')) line += c;
    }
    if (line.find(part) != std::string::npos) return line;
    from = end + 1;
  }
  return "(no line with " + part + ")";
}

InstanceIo node(const std::string& name, int robot, bus::ProcessIo io) {
  InstanceIo n{LaunchInstance{}, std::move(io)};
  n.instance.name = name;
  n.instance.robot = robot;
  n.instance.bus_url = "udpm://239.255.76.67:" + std::to_string(7667 + robot);
  return n;
}

std::vector<InstanceIo> robotPipeline(int robot) {
  return {node("camera", robot,
               bus::ProcessIo("camera")
                   .reads(bus::channels::kSimWorld)
                   .writes(bus::channels::kCameraImage)),
          node("tracker", robot,
               bus::ProcessIo("tracker")
                   .reads(bus::channels::kCameraImage)
                   .readsIfPresent(bus::channels::kRobotState)
                   .writes(bus::channels::kVisionLines)),
          node("bridge", robot,
               bus::ProcessIo("bridge")
                   .writes(bus::channels::kOdometry)
                   .link("serial", "/tmp/robot" + std::to_string(robot) + ".tty",
                         bus::Link::Direction::kBoth))};
}

std::vector<InstanceIo> team(int robots) {
  std::vector<InstanceIo> nodes{
      node("sim", kSimRobot,
           bus::ProcessIo("sim")
               .writes(bus::channels::kSimWorld)
               .link("serial", "/tmp/robot1.tty", bus::Link::Direction::kBoth)),
      node("viewer", kSimRobot,
           bus::ProcessIo("viewer").readsFromEveryRobot(bus::channels::kVisionLines))};
  for (int r = 1; r <= robots; ++r) {
    for (InstanceIo& n : robotPipeline(r))
      nodes.push_back(std::move(n));
  }
  return nodes;
}

TEST(LaunchGraph, EveryRequiredInputOfACompleteTeamHasAWriter) {
  const auto nodes = team(2);
  EXPECT_TRUE(missingWriters(nodes).empty());
  const std::string text = formatGraph(nodes);
  EXPECT_NE(text.find("robot 2 bus  udpm://239.255.76.67:7669"), std::string::npos) << text;
  EXPECT_EQ(lineWith(text, "writes SIM_WORLD"), "writes SIM_WORLD -> camera (r1, r2)");
  // The camera's input comes from the simulator's bus; the monitor reads every robot's lines.
  EXPECT_EQ(lineWith(text, "reads SIM_WORLD"), "reads SIM_WORLD (sim bus) <- sim (sim)");
  EXPECT_EQ(lineWith(text, "reads VISION_LINES"),
            "reads VISION_LINES on r1, r2 <- tracker (r1, r2) (used when present)");
  EXPECT_EQ(lineWith(text, "writes VISION_LINES"), "writes VISION_LINES -> viewer (sim)");
  // ROBOT_STATE has no writer, but the tracker only uses it when present.
  EXPECT_EQ(lineWith(text, "reads ROBOT_STATE"), "reads ROBOT_STATE <- nobody (used when present)");
  // The serial line's other end is named where the launch has it, else it is outside.
  EXPECT_EQ(lineWith(text, "/tmp/robot1.tty"), "serial /tmp/robot1.tty (both) <-> bridge (r1)");
  EXPECT_EQ(lineWith(text, "/tmp/robot2.tty"),
            "serial /tmp/robot2.tty (both) <-> outside the launch");
  EXPECT_NE(text.find("Every required input has a writer."), std::string::npos) << text;
}

TEST(LaunchGraph, AReaderWithoutAWriterOnItsOwnBusIsNamed) {
  auto nodes = team(2);
  // Robot 2's camera is missing: its tracker hears no CAMERA_IMAGE, even though robot 1 has one.
  std::erase_if(nodes, [](const InstanceIo& n) {
    return n.instance.name == "camera" && n.instance.robot == 2;
  });
  const auto missing = missingWriters(nodes);
  ASSERT_EQ(missing.size(), 1u);
  EXPECT_EQ(missing[0],
            "r2 tracker reads CAMERA_IMAGE on robot 2's bus: no process of the launch writes it");
  EXPECT_NE(formatGraph(nodes).find("Required inputs without a writer:"), std::string::npos);
}

TEST(LaunchGraph, ASimulatorsChannelNeedsTheSimulator) {
  auto nodes = team(1);
  std::erase_if(nodes, [](const InstanceIo& n) { return n.instance.name == "sim"; });
  const auto missing = missingWriters(nodes);
  ASSERT_EQ(missing.size(), 1u);
  EXPECT_EQ(missing[0],
            "r1 camera reads SIM_WORLD on the simulator's bus: no process of the launch writes it");
}

}  // namespace graph_test
}  // namespace fieldline::launch
