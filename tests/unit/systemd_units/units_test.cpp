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
  backoff: {initial_s: 0.25}
  crash_loop: {restarts: 4, window_s: 20}
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
    robots: all
    restart: never
    env: {LOG_LEVEL: debug}
robots:
  - {id: 2, clock: {offset_s: 0.25, drift_ppm: -20}}
)");
  const auto files = generateUnits(file, {.bin_dir = "/usr/local/bin"});
  ASSERT_EQ(files.count("fieldline-camera@.service"), 1u);
  const std::string& camera = files.at("fieldline-camera@.service");
  EXPECT_NE(camera.find("ExecStart=/usr/local/bin/fieldline-camera --robot %i --bus-url "
                        "${FIELDLINE_BUS_URL} --sim-bus-url ${FIELDLINE_SIM_BUS_URL} --device "
                        "/dev/cam%i 10%%\n"),
            std::string::npos)
      << camera;
  EXPECT_NE(camera.find("Restart=always\n"), std::string::npos);
  EXPECT_NE(camera.find("RestartSec=0.25s\n"), std::string::npos);
  EXPECT_NE(camera.find("TimeoutStopSec=4.5s\n"), std::string::npos);
  // The launch file's crash loop is systemd's start limit.
  EXPECT_NE(camera.find("StartLimitIntervalSec=20s\nStartLimitBurst=4\n"), std::string::npos);
  // fieldline's own processes: notify and watchdog; anything else is simple.
  EXPECT_NE(camera.find("Type=notify\nNotifyAccess=main\nWatchdogSec=10s\n"), std::string::npos);
  EXPECT_NE(camera.find("PartOf=fieldline-robot@%i.target\n"), std::string::npos);
  EXPECT_NE(camera.find("EnvironmentFile=/etc/fieldline/robot%i.env\n"), std::string::npos);
  const std::string& logger = files.at("fieldline-logger@.service");
  EXPECT_NE(logger.find("ExecStart=/opt/log "), std::string::npos);
  EXPECT_NE(logger.find("Restart=no\n"), std::string::npos);
  EXPECT_NE(logger.find("Type=simple\n"), std::string::npos);
  EXPECT_EQ(logger.find("WatchdogSec"), std::string::npos);
  EXPECT_NE(logger.find("Environment=LOG_LEVEL=debug\n"), std::string::npos);
  EXPECT_NE(files.at("fieldline-world_sim@.service").find("PartOf=fieldline-sim.target\n"),
            std::string::npos);

  // One robot target for every robot, the instance being the robot; the simulator's own.
  const std::string& robot = files.at("fieldline-robot@.target");
  EXPECT_NE(robot.find("Wants=fieldline-camera@%i.service\nWants=fieldline-logger@%i.service\n"),
            std::string::npos)
      << robot;
  EXPECT_EQ(robot.find("world_sim"), std::string::npos);
  EXPECT_NE(files.at("fieldline-sim.target").find("Wants=fieldline-world_sim@0.service\n"),
            std::string::npos);

  // Each robot's own port, the simulator's on base_port; robot 2's clock error.
  EXPECT_NE(files.at("robot2.env").find("FIELDLINE_BUS_URL=udpm://239.255.76.67:7702?"),
            std::string::npos);
  EXPECT_NE(files.at("robot0.env").find("FIELDLINE_BUS_URL=udpm://239.255.76.67:7700?"),
            std::string::npos);
  EXPECT_NE(files.at("robot2.env").find("FIELDLINE_CLOCK_OFFSET_US=250000\n"), std::string::npos)
      << files.at("robot2.env");
  EXPECT_NE(files.at("robot2.env").find("FIELDLINE_CLOCK_DRIFT_PPM=-20\n"), std::string::npos);
  EXPECT_EQ(files.at("robot1.env").find("FIELDLINE_CLOCK"), std::string::npos);
  EXPECT_EQ(files.count("robot3.env"), 0u);

  // ttl 0: the bus group's route on lo, wanted by every service.
  EXPECT_NE(
      files.at("fieldline-bus-route.service").find("ip route replace 239.255.76.67/32 dev lo"),
      std::string::npos);
  EXPECT_NE(camera.find("Wants=network-online.target fieldline-bus-route.service\n"),
            std::string::npos);

  // --robots widens `all` and the environment files.
  EXPECT_EQ(generateUnits(file, {.robots = 4}).count("robot4.env"), 1u);
}

TEST(SystemdUnits, BusesWatchedFromALaptopAreRoutedToTheirInterface) {
  const std::string processes =
      "processes:\n  - {name: camera, executable: fieldline-camera, robots: all}\n";
  auto files = generateUnits(parse("defaults:\n  bus: {ttl: 1, interface: wlan0}\n" + processes),
                             {.robots = 1});
  const std::string& route = files.at("fieldline-bus-route.service");
  EXPECT_NE(route.find("ip link set wlan0 multicast on && ip route replace 239.255.76.67/32 dev "
                       "wlan0"),
            std::string::npos)
      << route;
  EXPECT_NE(route.find("ttl 1 and leave through wlan0"), std::string::npos) << route;
  EXPECT_NE(files.at("robot1.env").find("ttl=1"), std::string::npos) << files.at("robot1.env");
  // A ttl without an interface keeps the system's route: no route unit.
  files = generateUnits(parse("defaults:\n  bus: {ttl: 1}\n" + processes), {.robots = 1});
  EXPECT_EQ(files.count("fieldline-bus-route.service"), 0u);
}

TEST(SystemdUnits, TheTeamKeyIsACredential) {
  const auto file = parse(R"(
processes:
  - name: teamcomm
    executable: fieldline-teamcomm
    robots: [1]
    args: [--team-config, real_team]
)");
  const std::string unit = generateUnits(file, {}).at("fieldline-teamcomm@.service");
  EXPECT_NE(unit.find("LoadCredential=team.key:/etc/fieldline/team.key\n"), std::string::npos)
      << unit;
  EXPECT_NE(unit.find("--team-config real_team --key-file %d/team.key\n"), std::string::npos);
  const std::string without =
      generateUnits(file, {.team_key = ""}).at("fieldline-teamcomm@.service");
  EXPECT_EQ(without.find("LoadCredential"), std::string::npos);
  EXPECT_EQ(without.find("--key-file"), std::string::npos);
}

TEST(SystemdUnits, RobotsMustRunTheSameProcesses) {
  // A process on some robots only cannot be part of the robot template.
  const auto uneven = parse(R"(
defaults: {robots: 2}
processes:
  - {name: camera, executable: fieldline-camera, robots: all}
  - {name: logger, executable: /opt/log, robots: [2]}
)");
  try {
    generateUnits(uneven, {});
    FAIL() << "uneven robots accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'logger' (line 5) runs on robots 2 but 'camera' on 1, 2"),
              std::string::npos)
        << e.what();
  }
  const auto mixed = parse(R"(
processes:
  - {name: both, executable: fieldline-camera, robots: [0, 1]}
)");
  EXPECT_THROW(generateUnits(mixed, {}), std::invalid_argument);
}

TEST(SystemdUnits, RelativeDirectoriesAreRefused) {
  const auto file = parse("processes:\n  - name: a\n    executable: a\n    robots: [1]\n");
  EXPECT_THROW(generateUnits(file, {.bin_dir = "build/bin"}), std::invalid_argument);
  EXPECT_THROW(generateUnits(file, {.env_dir = ""}), std::invalid_argument);
  EXPECT_THROW(generateUnits(file, {.team_key = "team.key"}), std::invalid_argument);
}

}  // namespace
}  // namespace fieldline::systemd_units
