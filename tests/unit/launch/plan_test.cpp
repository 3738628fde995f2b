#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <sys/stat.h>
#include <unistd.h>

#include "tools/launch/plan.hpp"

namespace fieldline::launch {
namespace plan_test {

const std::string kRobot3Url = "udpm://239.255.76.67:7670?ttl=0&recv_buf_size=4194304";
const std::string kSimUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";

ProcessEntry entry(std::string name, std::vector<int> robots, bool all = false) {
  ProcessEntry e;
  e.name = std::move(name);
  e.executable = "fieldline-" + e.name;
  e.robots = std::move(robots);
  e.all_robots = all;
  return e;
}

TEST(CommandLine, RobotProcessGetsItsBusAndTheSimulatorsBus) {
  ProcessEntry e = entry("camera", {3});
  e.args = {"--source", "sim", "--log", "/tmp/cam{robot}.log"};
  const auto argv = buildCommandLine(e, 3, bus::BusAddress{}, "/build/bin/fieldline-camera");
  const std::vector<std::string> expected{"/build/bin/fieldline-camera",
                                          "--robot",
                                          "3",
                                          "--bus-url",
                                          kRobot3Url,
                                          "--sim-bus-url",
                                          kSimUrl,
                                          "--source",
                                          "sim",
                                          "--log",
                                          "/tmp/cam3.log"};
  EXPECT_EQ(argv, expected);
}

TEST(CommandLine, TeamWideProcessUsesTheSimulatorsBus) {
  const auto argv = buildCommandLine(entry("world_sim", {kSimRobot}), kSimRobot, {}, "");
  const std::vector<std::string> expected{
      "fieldline-world_sim", "--robot", "0", "--bus-url", kSimUrl, "--sim-bus-url", kSimUrl};
  EXPECT_EQ(argv, expected);
}

TEST(CommandLine, BusAddressFromTheLaunchFile) {
  bus::BusAddress address;
  address.group = "239.1.2.3";
  address.base_port = 9000;
  address.ttl = 1;
  address.recv_buf_size = 1 << 20;
  const auto argv = buildCommandLine(entry("x", {2}), 2, address, "/x");
  EXPECT_EQ(argv[4], "udpm://239.1.2.3:9002?ttl=1&recv_buf_size=1048576");
  EXPECT_EQ(argv[6], "udpm://239.1.2.3:9000?ttl=1&recv_buf_size=1048576");
}

TEST(CommandLine, SubstituteRobot) {
  EXPECT_EQ(substituteRobot("{robot}", 4), "4");
  EXPECT_EQ(substituteRobot("r{robot}_{robot}.yaml", 12), "r12_12.yaml");
  EXPECT_EQ(substituteRobot("plain", 1), "plain");
  EXPECT_EQ(substituteRobot("{robo}", 1), "{robo}");
}

TEST(CommandLine, ShellQuoting) {
  EXPECT_EQ(commandText({"/bin/x", "--a", "b c", "it's", "", "u?v&w"}),
            "/bin/x --a 'b c' 'it'\\''s' '' 'u?v&w'");
}

TEST(Plan, OrdersBySimulatorThenRobotThenFileOrder) {
  LaunchFile file;
  file.processes.push_back(entry("camera", {}, /*all=*/true));
  file.processes.push_back(entry("world_sim", {kSimRobot}));
  file.processes.push_back(entry("fusion", {2, 1, 5}));
  const LaunchPlan plan = planLaunch(file, 2, [](const std::string& exe) {
    return exe == "fieldline-fusion" ? "" : "/bin/" + exe;
  });
  std::vector<std::string> labels;
  for (const auto& i : plan.instances)
    labels.push_back(i.label());
  EXPECT_EQ(labels, (std::vector<std::string>{"sim world_sim", "r1 camera", "r1 fusion",
                                              "r2 camera", "r2 fusion"}));
  ASSERT_EQ(plan.notes.size(), 1u);
  EXPECT_EQ(plan.notes[0], "fusion for robot 5 left out: the team has 2 robots");

  const LaunchInstance& fusion = plan.instances[2];
  EXPECT_TRUE(fusion.path.empty());  // not built
  EXPECT_EQ(fusion.argv[0], "fieldline-fusion");
  EXPECT_EQ(fusion.bus_url, "udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(plan.instances[0].bus_url, kSimUrl);
  EXPECT_EQ(plan.instances[0].path, "/bin/fieldline-world_sim");
}

class FindExecutable : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() / ("launch_find_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir / "bin");
    std::filesystem::create_directories(dir / "path");
    touch(dir / "bin" / "tool", 0755);
    touch(dir / "bin" / "data", 0644);
    touch(dir / "path" / "other", 0755);
    touch(dir / "path" / "tool", 0755);
  }
  void TearDown() override { std::filesystem::remove_all(dir); }
  static void touch(const std::filesystem::path& p, mode_t mode) {
    std::ofstream(p) << "#!/bin/sh\n";
    ::chmod(p.c_str(), mode);
  }
  std::filesystem::path dir;
};

TEST_F(FindExecutable, BinDirFirstThenPath) {
  const std::string bin = (dir / "bin").string();
  const std::string path = "/nonexistent:" + (dir / "path").string();
  EXPECT_EQ(findExecutable("tool", bin, path.c_str()), (dir / "bin" / "tool").string());
  EXPECT_EQ(findExecutable("other", bin, path.c_str()), (dir / "path" / "other").string());
  EXPECT_EQ(findExecutable("data", bin, path.c_str()), "");  // not executable
  EXPECT_EQ(findExecutable("missing", bin, path.c_str()), "");
  EXPECT_EQ(findExecutable("other", bin, nullptr), "");
}

TEST_F(FindExecutable, PathsAreTakenAsGiven) {
  const std::string tool = (dir / "path" / "tool").string();
  EXPECT_EQ(findExecutable(tool, "", nullptr), tool);
  EXPECT_EQ(findExecutable((dir / "bin" / "data").string(), "", nullptr), "");
}

TEST(SelfDirectory, IsWhereTheTestBinaryLives) {
  const std::string dir = selfDirectory();
  ASSERT_FALSE(dir.empty());
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(dir) / "launch_test"));
}

}  // namespace plan_test
}  // namespace fieldline::launch
