// The systemd unit generator: what the launch file says ends up in the units, escaped so the
// process gets its arguments unchanged.
#include <gtest/gtest.h>

#include "common/config/config.hpp"
#include "tools/launch/launch_file.hpp"
#include "tools/systemd_units/units.hpp"

namespace fieldline::systemd_units {
namespace {

launch::LaunchFile parse(const std::string& yaml) {
  return launch::parseLaunchFile(config::Node::loadString(yaml, "test.yaml"));
}

TEST(SystemdUnits, ExecWordsReachTheProcessUnchanged) {
  EXPECT_EQ(execWord("--field"), "--field");
  EXPECT_EQ(execWord("50%"), "50%%");
  EXPECT_EQ(execWord("$HOME"), "$$HOME");
  EXPECT_EQ(execWord("two words"), "\"two words\"");
  EXPECT_EQ(execWord("say \"hi\""), "\"say \\\"hi\\\"\"");
  EXPECT_EQ(execWord(""), "\"\"");
}

TEST(SystemdUnits, ServicesTargetsAndBusesFollowTheLaunchFile) {
  const auto file = parse(R"(
defaults:
  robots: 2
  restart: on-failure
  stop_grace_s: 4.5
  bus: {group: 239.255.76.67, base_port: 7700, ttl: 0, recv_buf_size: 4194304}
processes:
  - name: world_sim
    executable: fieldline-world-sim
    robots: sim
  - name: camera
    executable: fieldline-camera
    robots: all
    args: [--device, "/dev/cam{robot}", "10%"]
    restart: always
  - name: logger
    executable: /opt/log
    robots: [2]
    restart: never
)");
  const auto files = generateUnits(file, {});
  ASSERT_EQ(files.count("fieldline-camera@.service"), 1u);
  const std::string& camera = files.at("fieldline-camera@.service");
  EXPECT_NE(camera.find("ExecStart=/usr/local/bin/fieldline-camera --robot %i --bus-url "
                        "${FIELDLINE_BUS_URL} --sim-bus-url ${FIELDLINE_SIM_BUS_URL} --device "
                        "/dev/cam%i 10%%\n"),
            std::string::npos)
      << camera;
  EXPECT_NE(camera.find("Restart=always\n"), std::string::npos);
  EXPECT_NE(camera.find("TimeoutStopSec=4.5s\n"), std::string::npos);
  EXPECT_NE(files.at("fieldline-logger@.service").find("ExecStart=/opt/log "), std::string::npos);
  EXPECT_NE(files.at("fieldline-logger@.service").find("Restart=no\n"), std::string::npos);

  // Robot 1: the camera; robot 2: the camera and the logger; 0: the simulator.
  const std::string& robot1 = files.at("fieldline-robot1.target");
  EXPECT_NE(robot1.find("Wants=fieldline-camera@1.service\n"), std::string::npos);
  EXPECT_EQ(robot1.find("logger"), std::string::npos);
  EXPECT_NE(files.at("fieldline-robot2.target").find("Wants=fieldline-logger@2.service\n"),
            std::string::npos);
  EXPECT_NE(files.at("fieldline-robot0.target").find("Wants=fieldline-world_sim@0.service\n"),
            std::string::npos);
  EXPECT_EQ(files.count("fieldline-robot3.target"), 0u);

  // Each robot's own port, the simulator's on base_port.
  EXPECT_NE(files.at("robot2.env").find("FIELDLINE_BUS_URL=udpm://239.255.76.67:7702?"),
            std::string::npos);
  EXPECT_NE(files.at("robot0.env").find("FIELDLINE_BUS_URL=udpm://239.255.76.67:7700?"),
            std::string::npos);

  // --robots widens `all`.
  EXPECT_EQ(generateUnits(file, {.robots = 4}).count("fieldline-robot4.target"), 1u);
}

TEST(SystemdUnits, RelativeDirectoriesAreRefused) {
  const auto file = parse("processes:\n  - name: a\n    executable: a\n    robots: [1]\n");
  EXPECT_THROW(generateUnits(file, {.bin_dir = "build/bin"}), std::invalid_argument);
  EXPECT_THROW(generateUnits(file, {.env_dir = ""}), std::invalid_argument);
}

}  // namespace
}  // namespace fieldline::systemd_units
