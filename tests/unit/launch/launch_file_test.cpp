#include <gtest/gtest.h>

#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "tools/launch/launch_file.hpp"

namespace fieldline::launch {
namespace launch_file_test {

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
  EXPECT_NE(errorOf("defaults:\n  robts: 3\nprocesses:\n  - {name: a, executable: b, robots: 1}\n")
                .find("team.yaml:2: defaults.robts: unknown key"),
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
  EXPECT_EQ(real.defaults.robot, 1);
}

// A folder with files for the include tests, removed at the end.
class IncludeFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    scratch_dir = std::filesystem::temp_directory_path() /
                  ("launch_include_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(scratch_dir);
    write("robot.yaml", R"(# shared
processes:
  - name: camera
    executable: fieldline-camera
    robots: all
    args: [--field, "{field}"]
  - name: pilot
    executable: fieldline-pilot
    robots: all
    main_channel: MOTION_COMMAND
)");
  }
  void TearDown() override { std::filesystem::remove_all(scratch_dir); }

  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (scratch_dir / name).string();
    std::ofstream(path) << text;
    return path;
  }
  LaunchFile load(const std::string& text, const LaunchOverrides& overrides = {}) {
    return loadLaunchFile(write("main.yaml", text), overrides);
  }
  std::string errorOfFile(const std::string& text, const LaunchOverrides& overrides = {}) {
    try {
      load(text, overrides);
    } catch (const config::Error& e) {
      return e.what();
    }
    return "no error";
  }

  std::filesystem::path scratch_dir;
};

TEST_F(IncludeFiles, IncludedProcessesComeFirstAndAreChangedByName) {
  const LaunchFile f = load(R"(include: robot.yaml
settings: {field: msl}
defaults: {restart: always}
processes:
  - name: world_sim
    executable: fieldline-world-sim
    robots: sim
  - name: pilot
    args: [--scenario, kidnap]
    restart: never
    env: {MODE: "{field}"}
)");
  EXPECT_EQ(f.include_path, (scratch_dir / "robot.yaml").string());
  EXPECT_EQ(f.included, (std::vector<std::string>{"camera", "pilot"}));
  ASSERT_EQ(f.processes.size(), 3u);
  EXPECT_EQ(f.processes[0].name, "camera");
  EXPECT_EQ(f.processes[0].file, (scratch_dir / "robot.yaml").string());
  EXPECT_EQ(f.processes[0].line, 3);
  EXPECT_EQ(f.processes[0].args, (std::vector<std::string>{"--field", "msl"}));
  EXPECT_EQ(f.processes[0].restart, RestartPolicy::kAlways);  // the including file's defaults
  EXPECT_EQ(f.processes[1].name, "pilot");
  EXPECT_EQ(f.processes[1].args, (std::vector<std::string>{"--scenario", "kidnap"}));
  EXPECT_EQ(f.processes[1].restart, RestartPolicy::kNever);
  EXPECT_EQ(f.processes[1].env.at("MODE"), "msl");
  EXPECT_EQ(f.processes[1].main_channel, "MOTION_COMMAND");
  EXPECT_EQ(f.processes[2].name, "world_sim");
  EXPECT_EQ(f.processes[2].file, (scratch_dir / "main.yaml").string());
}

TEST_F(IncludeFiles, SettingsComeFromTheFileTheEnvironmentAndSetInThatOrder) {
  const std::string text = R"(include: robot.yaml
settings:
  field: msl
  camera_device: /dev/video0
processes:
  - name: camera
    args: [--input, "{camera_device}", --log, "cam{robot}.log", "{not a name}"]
)";
  const LaunchFile plain = load(text);
  EXPECT_EQ(plain.processes[0].args,
            (std::vector<std::string>{"--field", "msl", "--input", "/dev/video0", "--log",
                                      "cam{robot}.log", "{not a name}"}));
  EXPECT_EQ(plain.settings.at("camera_device").origin, "launch file");

  std::map<std::string, std::string> env{{"FIELDLINE_CAMERA_DEVICE", "/tmp/frames.fifo"},
                                         {"FIELDLINE_FIELD", ""}};
  LaunchOverrides overrides;
  overrides.environment = [&](const std::string& name) -> std::optional<std::string> {
    const auto it = env.find(name);
    if (it == env.end()) return std::nullopt;
    return it->second;
  };
  const LaunchFile from_env = load(text, overrides);
  EXPECT_EQ(from_env.processes[0].args[3], "/tmp/frames.fifo");
  EXPECT_EQ(from_env.settings.at("camera_device").origin, "environment FIELDLINE_CAMERA_DEVICE");
  EXPECT_EQ(from_env.settings.at("field").value, "msl");  // an empty variable is not a value

  overrides.settings["camera_device"] = "/dev/video4";
  const LaunchFile from_set = load(text, overrides);
  EXPECT_EQ(from_set.processes[0].args[3], "/dev/video4");
  EXPECT_EQ(from_set.settings.at("camera_device").origin, "--set");
}

TEST_F(IncludeFiles, ANameThatIsNoSettingIsAnErrorAtItsLine) {
  // {field} in the included file, no such setting in the including one.
  const std::string e = errorOfFile("include: robot.yaml\nsettings: {camera: x}\n");
  EXPECT_NE(
      e.find((scratch_dir / "robot.yaml").string() + ":6: processes[0].args: {field} is not a "
                                                     "setting of"),
      std::string::npos)
      << e;
  EXPECT_NE(e.find("(its settings: camera)"), std::string::npos) << e;
  const std::string unknown_set =
      errorOfFile("include: robot.yaml\nsettings: {field: msl}\n", {.settings = {{"feild", "x"}}});
  EXPECT_NE(unknown_set.find("--set feild: not a setting of"), std::string::npos) << unknown_set;
  EXPECT_NE(unknown_set.find("(its settings: field)"), std::string::npos) << unknown_set;
  EXPECT_NE(errorOfFile("settings: {Bad-Name: 1}\nprocesses:\n  - {name: a, executable: b, robots: "
                        "1}\n")
                .find("settings.Bad-Name: a setting's name is lower-case"),
            std::string::npos);
}

TEST_F(IncludeFiles, AnIncludedProcessMayRunAnotherExecutableButIsChangedOnlyOnce) {
  const LaunchFile f = load(R"(include: robot.yaml
settings: {field: msl}
processes:
  - name: camera
    executable: my-camera
)");
  EXPECT_EQ(f.processes[0].executable, "my-camera");
  EXPECT_EQ(f.processes[0].args, (std::vector<std::string>{"--field", "msl"}));
  const std::string e = errorOfFile(R"(include: robot.yaml
settings: {field: msl}
processes:
  - {name: camera, args: [-a]}
  - {name: camera, args: [-b]}
)");
  EXPECT_NE(e.find("main.yaml:5: processes[1].name: 'camera' is changed twice"), std::string::npos)
      << e;
}

TEST_F(IncludeFiles, EnabledFalseLeavesAnIncludedProcessOut) {
  const LaunchFile f = load(R"(include: robot.yaml
settings: {field: msl}
processes:
  - name: camera
    enabled: false
)");
  ASSERT_EQ(f.processes.size(), 1u);
  EXPECT_EQ(f.processes[0].name, "pilot");
  // Only an included process can be left out.
  const std::string e = errorOfFile(R"(include: robot.yaml
settings: {field: msl}
processes:
  - {name: x, executable: y, robots: 1, enabled: false}
)");
  EXPECT_NE(e.find("processes[0].enabled: unknown key"), std::string::npos) << e;
}

TEST_F(IncludeFiles, AnIncludedFileHoldsOnlyProcesses) {
  write("with_defaults.yaml",
        "defaults: {robots: 2}\nprocesses:\n  - {name: a, executable: b, "
        "robots: 1}\n");
  const std::string e = errorOfFile("include: with_defaults.yaml\n");
  EXPECT_NE(e.find("with_defaults.yaml:1: defaults: unknown key"), std::string::npos) << e;
  write("nested.yaml", "include: robot.yaml\nprocesses: []\n");
  EXPECT_NE(errorOfFile("include: nested.yaml\n").find("an included file cannot include another"),
            std::string::npos);
}

TEST_F(IncludeFiles, ThisRobotMakesAllMeanOneRobot) {
  const std::string text = R"(include: robot.yaml
settings: {field: msl}
defaults: {robots: 6, robot: 3}
processes:
  - {name: sim_tool, executable: x, robots: sim}
  - {name: logger, executable: y, robots: [1, 2]}
)";
  const LaunchFile f = load(text);
  EXPECT_EQ(f.defaults.robot, 3);
  EXPECT_EQ(entryRobots(f.processes[0], f.defaults, 6), std::vector<int>{3});
  EXPECT_EQ(entryRobots(f.processes[2], f.defaults, 6), std::vector<int>{kSimRobot});
  EXPECT_EQ(entryRobots(f.processes[3], f.defaults, 6), (std::vector<int>{1, 2}));
  std::map<std::string, std::string> env{{"FIELDLINE_ROBOT", "5"}};
  LaunchOverrides overrides;
  overrides.environment = [&](const std::string& name) -> std::optional<std::string> {
    const auto it = env.find(name);
    if (it == env.end()) return std::nullopt;
    return it->second;
  };
  EXPECT_EQ(load(text, overrides).defaults.robot, 5);
  overrides.robot = 2;
  EXPECT_EQ(load(text, overrides).defaults.robot, 2);
  overrides.robot = 0;
  env["FIELDLINE_ROBOT"] = "seven";
  EXPECT_NE(errorOfFile(text, overrides).find("FIELDLINE_ROBOT: expected a robot number"),
            std::string::npos);
  // Without a robot of its own, `all` is the team.
  LaunchDefaults team;
  EXPECT_EQ(entryRobots(f.processes[0], team, 2), (std::vector<int>{1, 2}));
}

}  // namespace launch_file_test
}  // namespace fieldline::launch
