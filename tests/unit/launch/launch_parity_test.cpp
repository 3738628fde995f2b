// ctest -R launch_parity: the real robot's launch file runs every per-robot process of the
// simulated team (both include config/launch/robot_processes.yaml), and its camera is a real
// camera's. The check itself must catch a process left out, added to one side only, or run with
// another executable: each is shown on a changed copy of the shipped files.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/config/config.hpp"
#include "services/camera/camera_config.hpp"
#include "tools/launch/launch_file.hpp"
#include "tools/launch/parity.hpp"

namespace fieldline::launch {
namespace {

std::string shippedPath(const std::string& name) {
  return config::resolvePreset("launch", name);
}

std::string shippedText(const std::string& name) {
  std::ifstream in(shippedPath(name));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The shipped file as read without overrides (the environment is not read).
LaunchFile shipped(const std::string& name) {
  return loadLaunchFile(shippedPath(name));
}

// `text` parsed as if it were the shipped file `name` (its include resolves the same way).
LaunchFile parseAs(const std::string& name, const std::string& text) {
  return parseLaunchFile(config::Node::loadString(text, shippedPath(name)));
}

// The team's file with `entry` added to its processes (before its clocks section).
std::string teamWith(const std::string& entry) {
  std::string text = shippedText("sim_team");
  const std::size_t clocks = text.find("\nrobots:");
  EXPECT_NE(clocks, std::string::npos);
  return text.insert(clocks + 1, entry);
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines)
    out += l + "\n";
  return out;
}

const ProcessEntry& entry(const LaunchFile& f, const std::string& name) {
  const auto it = std::find_if(f.processes.begin(), f.processes.end(),
                               [&](const ProcessEntry& p) { return p.name == name; });
  if (it == f.processes.end()) throw std::runtime_error(name + " is not in " + f.path);
  return *it;
}

// The value after `option` in `args`, or "".
std::string argAfter(const std::vector<std::string>& args, const std::string& option) {
  const auto it = std::find(args.begin(), args.end(), option);
  return it == args.end() || it + 1 == args.end() ? "" : *(it + 1);
}

TEST(LaunchParity, RealRobotRunsEveryPerRobotProcessOfTheSimulatedTeam) {
  const LaunchFile team = shipped("sim_team");
  const LaunchFile robot = shipped("real_robot");
  const std::vector<std::string> problems = parityProblems(team, robot);
  EXPECT_TRUE(problems.empty()) << joined(problems);
  const std::vector<std::string> names = perRobotProcesses(team);
  for (const std::string expected : {"camera", "region_tracking", "feature_recognition", "fusion",
                                     "teamcomm", "motor_bridge", "pilot"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  // The simulator's own processes stay out of the real launch.
  for (const std::string sim_only : {"world_sim", "viewer"}) {
    EXPECT_EQ(std::find(names.begin(), names.end(), sim_only), names.end()) << sim_only;
    EXPECT_FALSE(std::any_of(robot.processes.begin(), robot.processes.end(),
                             [&](const ProcessEntry& p) { return p.name == sim_only; }))
        << sim_only;
  }
  std::string compared;
  for (const std::string& n : names)
    compared += " " + n;
  std::printf("per-robot processes of sim_team, all in real_robot:%s\n", compared.c_str());
}

TEST(LaunchParity, BothLaunchFilesIncludeOneDescriptionOfARobotsProcesses) {
  const LaunchFile team = shipped("sim_team");
  const LaunchFile robot = shipped("real_robot");
  EXPECT_FALSE(team.include_path.empty());
  EXPECT_EQ(team.include_path, robot.include_path);
  // Every per-robot process of the team comes from the shared file.
  for (const std::string& name : perRobotProcesses(team)) {
    EXPECT_NE(std::find(team.included.begin(), team.included.end(), name), team.included.end())
        << name << " is defined in sim_team.yaml itself, not in " << team.include_path;
  }
}

TEST(LaunchParity, AProcessTheRealLaunchLeavesOutIsReported) {
  const LaunchFile team = shipped("sim_team");
  const LaunchFile robot =
      parseAs("real_robot", shippedText("real_robot") + "\n  - name: fusion\n    enabled: false\n");
  const std::vector<std::string> problems = parityProblems(team, robot);
  ASSERT_EQ(problems.size(), 1u) << joined(problems);
  EXPECT_NE(problems[0].find("fusion ("), std::string::npos) << problems[0];
  EXPECT_NE(problems[0].find("robot_processes.yaml:"), std::string::npos) << problems[0];
  EXPECT_NE(problems[0].find("missing from"), std::string::npos) << problems[0];
}

TEST(LaunchParity, AProcessAddedToTheSimulatedTeamAloneIsReported) {
  const LaunchFile team = parseAs("sim_team", teamWith(R"(  - name: ball_predictor
    executable: fieldline-ball-predictor
    robots: all
)"));
  const std::vector<std::string> problems = parityProblems(team, shipped("real_robot"));
  ASSERT_EQ(problems.size(), 1u) << joined(problems);
  EXPECT_NE(problems[0].find("ball_predictor (" + shippedPath("sim_team")), std::string::npos)
      << problems[0];
  // A process of the simulator alone is not the robot's business.
  const LaunchFile with_sim_tool = parseAs("sim_team", teamWith(R"(  - name: referee
    executable: fieldline-referee
    robots: sim
)"));
  EXPECT_TRUE(parityProblems(with_sim_tool, shipped("real_robot")).empty());
}

TEST(LaunchParity, AnotherExecutableOrAnotherRobotIsReported) {
  const LaunchFile team = shipped("sim_team");
  const LaunchFile other_exe = parseAs("real_robot", R"(defaults: {robot: 2}
processes:
  - {name: camera, executable: fieldline-camera, robots: all}
  - {name: region_tracking, executable: fieldline-region-tracking, robots: all}
  - {name: motor_bridge, executable: my-motor-driver, robots: all}
  - {name: pilot, executable: fieldline-pilot, robots: all}
  - {name: feature_recognition, executable: fieldline-feature-recognition, robots: all}
  - {name: fusion, executable: fieldline-fusion, robots: [1]}
  - {name: teamcomm, executable: fieldline-teamcomm, robots: all}
)");
  const std::vector<std::string> problems = parityProblems(team, other_exe);
  ASSERT_EQ(problems.size(), 2u) << joined(problems);
  EXPECT_NE(problems[0].find("runs my-motor-driver instead of fieldline-motor-bridge"),
            std::string::npos)
      << problems[0];
  EXPECT_NE(problems[1].find("fusion ("), std::string::npos) << problems[1];
  EXPECT_NE(problems[1].find("does not run it for its robot 2"), std::string::npos) << problems[1];
}

TEST(LaunchParity, TheRealLaunchUsesARealCameraDevicesAndAPilotThatHoldsStill) {
  const LaunchFile robot = shipped("real_robot");
  const ProcessEntry& camera = entry(robot, "camera");
  EXPECT_EQ(argAfter(camera.args, "--source"), "v4l2");
  EXPECT_EQ(argAfter(camera.args, "--input"), "/dev/video0");
  EXPECT_EQ(argAfter(entry(robot, "motor_bridge").args, "--device"), "/dev/ttyUSB0");
  // No scenario: the pilot sends nothing, a real robot never drives on its own.
  const ProcessEntry& pilot = entry(robot, "pilot");
  EXPECT_EQ(std::find(pilot.args.begin(), pilot.args.end(), "--scenario"), pilot.args.end());
  // The camera preset is a real camera's: no render section (the calibration tools write none),
  // the same preset for the camera and the region tracker.
  const std::string preset = argAfter(camera.args, "--config");
  ASSERT_FALSE(preset.empty());
  EXPECT_EQ(argAfter(entry(robot, "region_tracking").args, "--camera"), preset);
  const camera::CameraConfig config = camera::loadCameraConfigPreset(preset);
  EXPECT_FALSE(config.render.has_value()) << config.source << " has a render section";
  EXPECT_NE(config.model.colour_table, "colours_sim") << "the simulator's colour classes";
}

}  // namespace
}  // namespace fieldline::launch
