#include <gtest/gtest.h>

#include <string>

#include "tools/launch/launch_file.hpp"

namespace fieldline::launch {
namespace {

LaunchFile parse(const std::string& text) {
  return parseLaunchFile(config::Node::loadString(text, "team.yaml"));
}

// The message of the config::Error that parsing `text` throws.
std::string errorOf(const std::string& text) {
  try {
    parse(text);
  } catch (const config::Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(LaunchFile, ReadsEveryKey) {
  const LaunchFile f = parse(R"(defaults:
  robots: 4
  restart: always
  stop_grace_s: 1.5
  backoff: {initial_s: 0.25, max_s: 4, stable_s: 30}
  bus: {group: 239.255.1.2, base_port: 9000, ttl: 1, recv_buf_size: 1048576}
processes:
  - name: world_sim
    executable: fieldline-world-sim
    robots: sim
    restart: never
  - name: camera
    executable: fieldline-camera
    robots: all
    args: [--source, sim, 30]
    env: {OMP_NUM_THREADS: 1, MODE: fast}
    main_channel: CAMERA_IMAGE
  - name: fusion
    executable: /opt/fusion
    robots: [1, 3]
)");
  EXPECT_EQ(f.path, "team.yaml");
  EXPECT_EQ(f.defaults.robots, 4);
  EXPECT_EQ(f.defaults.restart, RestartPolicy::kAlways);
  EXPECT_DOUBLE_EQ(f.defaults.stop_grace_s, 1.5);
  EXPECT_DOUBLE_EQ(f.defaults.backoff.initial_s, 0.25);
  EXPECT_DOUBLE_EQ(f.defaults.backoff.max_s, 4.0);
  EXPECT_DOUBLE_EQ(f.defaults.backoff.stable_s, 30.0);
  EXPECT_EQ(f.defaults.bus.group, "239.255.1.2");
  EXPECT_EQ(f.defaults.bus.base_port, 9000);
  EXPECT_EQ(f.defaults.bus.ttl, 1);
  EXPECT_EQ(f.defaults.bus.recv_buf_size, 1048576);
  ASSERT_EQ(f.processes.size(), 3u);

  const ProcessEntry& sim = f.processes[0];
  EXPECT_EQ(sim.name, "world_sim");
  EXPECT_EQ(sim.executable, "fieldline-world-sim");
  EXPECT_FALSE(sim.all_robots);
  EXPECT_EQ(sim.robots, std::vector<int>{kSimRobot});
  EXPECT_EQ(sim.restart, RestartPolicy::kNever);
  EXPECT_TRUE(sim.args.empty());
  EXPECT_EQ(sim.line, 8);

  const ProcessEntry& camera = f.processes[1];
  EXPECT_TRUE(camera.all_robots);
  EXPECT_TRUE(camera.robots.empty());
  EXPECT_EQ(camera.args, (std::vector<std::string>{"--source", "sim", "30"}));
  EXPECT_EQ(camera.restart, RestartPolicy::kAlways);  // from defaults
  EXPECT_EQ(camera.env.at("OMP_NUM_THREADS"), "1");
  EXPECT_EQ(camera.env.at("MODE"), "fast");
  EXPECT_EQ(camera.main_channel, "CAMERA_IMAGE");

  EXPECT_EQ(f.processes[2].robots, (std::vector<int>{1, 3}));
  EXPECT_EQ(f.processes[2].line, 18);
}

TEST(LaunchFile, DefaultsWhenTheSectionIsAbsent) {
  const LaunchFile f = parse("processes:\n  - {name: a, executable: b, robots: 2}\n");
  EXPECT_EQ(f.defaults.robots, 6);
  EXPECT_EQ(f.defaults.restart, RestartPolicy::kOnFailure);
  EXPECT_DOUBLE_EQ(f.defaults.backoff.initial_s, 0.5);
  EXPECT_DOUBLE_EQ(f.defaults.backoff.max_s, 10.0);
  EXPECT_DOUBLE_EQ(f.defaults.backoff.stable_s, 60.0);
  EXPECT_EQ(f.defaults.bus.base_port, 7667);
  EXPECT_EQ(f.processes[0].robots, std::vector<int>{2});
  EXPECT_EQ(f.processes[0].restart, RestartPolicy::kOnFailure);
}

TEST(LaunchFile, EmptyOptionalKeysAreAccepted) {
  const LaunchFile f =
      parse("processes:\n  - name: a\n    executable: b\n    robots: 0\n    args:\n");
  EXPECT_TRUE(f.processes[0].args.empty());
  EXPECT_EQ(f.processes[0].robots, std::vector<int>{kSimRobot});
}

TEST(LaunchFile, UnknownKeyNamesFileLineAndPath) {
  const std::string e = errorOf(R"(processes:
  - name: a
    executable: b
    robots: all
  - name: c
    executabel: d
    executable: d
    robots: all
)");
  EXPECT_NE(e.find("team.yaml:6: processes[1].executabel: unknown key"), std::string::npos) << e;
}

TEST(LaunchFile, UnknownTopLevelAndDefaultsKeys) {
  EXPECT_NE(errorOf("processes:\n  - {name: a, executable: b, robots: 1}\nprocess: []\n")
                .find("team.yaml:3: process: unknown key"),
            std::string::npos);
  EXPECT_NE(errorOf("defaults:\n  robot: 3\nprocesses:\n  - {name: a, executable: b, robots: 1}\n")
                .find("team.yaml:2: defaults.robot: unknown key"),
            std::string::npos);
  EXPECT_NE(errorOf("defaults:\n  backoff: {initial: 1}\nprocesses:\n"
                    "  - {name: a, executable: b, robots: 1}\n")
                .find("defaults.backoff.initial: unknown key"),
            std::string::npos);
}

TEST(LaunchFile, MissingKeys) {
  EXPECT_NE(errorOf("processes:\n  - name: a\n    robots: 1\n")
                .find("team.yaml:2: processes[0].executable: missing required key"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - name: a\n    executable: b\n")
                .find("processes[0].robots: missing required key"),
            std::string::npos);
  EXPECT_NE(errorOf("defaults: {robots: 2}\n").find("processes: missing required list"),
            std::string::npos);
  EXPECT_NE(errorOf("processes: []\n").find("team.yaml:1: processes: the list is empty"),
            std::string::npos);
}

TEST(LaunchFile, BadValuesNameTheKey) {
  EXPECT_NE(errorOf("processes:\n  - {name: a, executable: b, robots: 1, restart: sometimes}\n")
                .find("processes[0].restart: 'sometimes' is not one of: always, on-failure, never"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: 'a b', executable: b, robots: 1}\n")
                .find("processes[0].name: 'a b' must be letters, digits, _ or -"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, executable: b, robots: 1, main_channel: FOO}\n")
                .find("processes[0].main_channel: 'FOO' is not one of"),
            std::string::npos);
  EXPECT_NE(errorOf("defaults:\n  robots: 0\nprocesses:\n  - {name: a, executable: b, robots: 1}\n")
                .find("team.yaml:2: defaults.robots: value 0 out of range [1, 99]"),
            std::string::npos);
  EXPECT_NE(errorOf("defaults:\n  bus: {base_port: 80}\nprocesses:\n"
                    "  - {name: a, executable: b, robots: 1}\n")
                .find("defaults.bus.base_port: value 80 out of range"),
            std::string::npos);
  EXPECT_NE(errorOf("defaults:\n  stop_grace_s: .nan\nprocesses:\n"
                    "  - {name: a, executable: b, robots: 1}\n")
                .find("defaults.stop_grace_s: must be a finite number"),
            std::string::npos);
  EXPECT_NE(errorOf("defaults:\n  backoff:\n    initial_s: 2\n    max_s: 1\nprocesses:\n"
                    "  - {name: a, executable: b, robots: 1}\n")
                .find("team.yaml:4: defaults.backoff.max_s: must not be smaller than initial_s"),
            std::string::npos);
}

TEST(LaunchFile, RobotsErrors) {
  EXPECT_NE(errorOf("processes:\n  - name: a\n    executable: b\n    robots: seven\n")
                .find("team.yaml:4: processes[0].robots: expected `all`, `sim` or a robot number"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, executable: b, robots: 100}\n").find("got '100'"),
            std::string::npos);
  const std::string twice =
      errorOf("processes:\n  - name: a\n    executable: b\n    robots:\n      - 1\n      - 1\n");
  EXPECT_NE(twice.find("team.yaml:6: processes[0].robots[1]: robot 1 is listed twice"),
            std::string::npos)
      << twice;
  EXPECT_NE(errorOf("processes:\n  - {name: a, executable: b, robots: [all, 1]}\n")
                .find("processes[0].robots[0]: `all` cannot be combined"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, executable: b, robots: []}\n")
                .find("processes[0].robots: the list is empty"),
            std::string::npos);
  EXPECT_NE(errorOf("processes:\n  - {name: a, executable: b, robots: [-1]}\n")
                .find("processes[0].robots[0]: expected `all`"),
            std::string::npos);
}

TEST(LaunchFile, DuplicateNameNamesTheSecondEntry) {
  const std::string e = errorOf(R"(processes:
  - {name: cam, executable: a, robots: 1}
  - {name: cam, executable: b, robots: 2}
)");
  EXPECT_NE(e.find("team.yaml:3: processes[1].name: 'cam' is used twice"), std::string::npos) << e;
}

TEST(LaunchFile, ShippedLaunchFilesParse) {
  for (const std::string name : {"sim_team", "real_robot"}) {
    const LaunchFile f = loadLaunchFile(config::resolvePreset("launch", name));
    EXPECT_FALSE(f.processes.empty()) << name;
  }
  const LaunchFile real = loadLaunchFile(config::resolvePreset("launch", "real_robot"));
  EXPECT_EQ(real.defaults.robots, 1);
}

}  // namespace
}  // namespace fieldline::launch
