#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "common/config/config.hpp"

namespace fieldline::config {
namespace config_test {

struct Wheel {
  double angle;
  double radius;
};
struct Robot {
  std::string name;
  int ticks;
  double mass;
  bool simulated;
  std::vector<Wheel> wheels;
  std::string drive;
  double latency;
};

Robot loadRobot(const Node& n) {
  Robot r;
  const Node robot = n.child("robot");
  r.name = robot.get<std::string>("name");
  r.ticks = robot.get<int>("ticks_per_rev", 1, 100000);
  r.mass = robot.get<double>("mass", 0.1, 100.0);
  r.simulated = robot.getOr<bool>("simulated", false);
  r.drive = robot.getChoice("drive", {"omni3", "omni4", "diff"});
  r.latency = robot.getOr<double>("latency", 0.008, 0.0, 1.0);
  for (const Node& w : robot.children("wheels")) {
    r.wheels.push_back({w.get<double>("angle", -7.0, 7.0), w.get<double>("radius", 0.01, 0.5)});
    w.rejectUnknownKeys();
  }
  robot.rejectUnknownKeys();
  n.rejectUnknownKeys();
  return r;
}

class ConfigTest : public ::testing::Test {
 protected:
  // One folder per process (several build trees may run this test at once), removed after the
  // test: ctest runs every test in a process of its own, and the folders used to stay in /tmp.
  void TearDown() override {
    std::error_code ignored;
    std::filesystem::remove_all(scratchDir(), ignored);
  }
  static std::filesystem::path scratchDir() {
    return std::filesystem::temp_directory_path() /
           ("fieldline_config_test_" + std::to_string(::getpid()));
  }
  std::string write(const std::string& text) {
    const auto dir = scratchDir();
    std::filesystem::create_directories(dir);
    const auto path =
        dir /
        (std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".yaml");
    std::ofstream(path) << text;
    return path.string();
  }
  // The error message for loading `text`, which must fail.
  std::string errorOf(const std::string& text, std::string* path_out = nullptr) {
    const std::string path = write(text);
    if (path_out) *path_out = path;
    try {
      loadRobot(Node::loadFile(path));
    } catch (const Error& e) {
      return e.what();
    }
    ADD_FAILURE() << "no error for:\n" << text;
    return "";
  }
};

const char* kGood = R"(robot:
  name: fu2004
  ticks_per_rev: 768
  mass: 9.5
  drive: omni3
  wheels:
    - {angle: 0.0, radius: 0.04}
    - {angle: 2.094, radius: 0.04}
    - {angle: -2.094, radius: 0.04}
)";

TEST_F(ConfigTest, LoadsAValidFile) {
  const Robot r = loadRobot(Node::loadFile(write(kGood)));
  EXPECT_EQ(r.name, "fu2004");
  EXPECT_EQ(r.ticks, 768);
  EXPECT_DOUBLE_EQ(r.mass, 9.5);
  EXPECT_FALSE(r.simulated);
  EXPECT_DOUBLE_EQ(r.latency, 0.008);
  ASSERT_EQ(r.wheels.size(), 3u);
  EXPECT_DOUBLE_EQ(r.wheels[1].angle, 2.094);
}

TEST_F(ConfigTest, MissingKeyNamesFileLineAndPath) {
  std::string path;
  const std::string text = R"(robot:
  name: fu2004
  mass: 9.5
  drive: omni3
  wheels: []
)";
  const std::string e = errorOf(text, &path);
  EXPECT_NE(e.find(path + ":2: robot.ticks_per_rev: missing required key"), std::string::npos) << e;
}

TEST_F(ConfigTest, UnknownKeyNamesItsOwnLine) {
  std::string path;
  std::string text = kGood;
  text += "  wheel_radius: 0.04\n";
  const std::string e = errorOf(text, &path);
  EXPECT_NE(e.find(path + ":10: robot.wheel_radius: unknown key"), std::string::npos) << e;
}

TEST_F(ConfigTest, UnknownKeyInAListElement) {
  std::string path;
  std::string text = kGood;
  text.replace(text.find("{angle: 0.0, radius: 0.04}"), 26, "{angle: 0.0, radius: 0.04, radus: 1}");
  const std::string e = errorOf(text, &path);
  EXPECT_NE(e.find(path + ":7: robot.wheels[0].radus: unknown key"), std::string::npos) << e;
}

TEST_F(ConfigTest, WrongTypeNamesKeyAndValue) {
  std::string path;
  std::string text = kGood;
  text.replace(text.find("768"), 3, "many");
  const std::string e = errorOf(text, &path);
  EXPECT_NE(e.find(path + ":3: robot.ticks_per_rev: expected an integer, got 'many'"),
            std::string::npos)
      << e;
}

TEST_F(ConfigTest, OutOfRangeNamesTheRange) {
  std::string path;
  std::string text = kGood;
  text.replace(text.find("9.5"), 3, "950");
  const std::string e = errorOf(text, &path);
  EXPECT_NE(e.find(path + ":4: robot.mass: value 950 out of range [0.1, 100]"), std::string::npos)
      << e;
}

TEST_F(ConfigTest, NanIsRejected) {
  std::string path;
  std::string text = kGood;
  text.replace(text.find("9.5"), 3, ".nan");
  const std::string e = errorOf(text, &path);
  EXPECT_NE(e.find(path + ":4: robot.mass:"), std::string::npos) << e;
}

TEST_F(ConfigTest, BadChoiceListsTheChoices) {
  std::string path;
  std::string text = kGood;
  text.replace(text.find("omni3"), 5, "omni5");
  const std::string e = errorOf(text, &path);
  EXPECT_NE(e.find(path + ":5: robot.drive: 'omni5' is not one of: omni3, omni4, diff"),
            std::string::npos)
      << e;
}

TEST_F(ConfigTest, SyntaxErrorNamesLine) {
  std::string path;
  const std::string e = errorOf("robot:\n  name: [unclosed\n  mass: 1\n", &path);
  EXPECT_NE(e.find(path + ":"), std::string::npos) << e;
  EXPECT_NE(e.find("YAML syntax error"), std::string::npos) << e;
}

TEST_F(ConfigTest, MissingFileIsAClearError) {
  try {
    Node::loadFile("/nonexistent/robot.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/robot.yaml: file not found");
  }
}

TEST_F(ConfigTest, ListLengthIsChecked) {
  const Node n = Node::loadString("gains: [1, 2]\n", "mem.yaml");
  EXPECT_EQ(n.getList<double>("gains", 2).size(), 2u);
  try {
    n.getList<double>("gains", 3);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mem.yaml:1: gains: expected 3 elements, got 2"),
              std::string::npos)
        << e.what();
  }
}

TEST(Preset, ResolvesNamesAndPaths) {
  EXPECT_EQ(resolvePreset("field", "x/y.yaml"), "x/y.yaml");
  EXPECT_EQ(resolvePreset("field", "msl"), projectRoot() + "/config/field/msl.yaml");
}

}  // namespace config_test
}  // namespace fieldline::config

namespace fieldline::config {
namespace config_test {

TEST(ConfigMore, BadListElementNamesItsOwnLine) {
  const Node n = Node::loadString("a: 1\ngains:\n  - 1.0\n  - 2.0\n  - x\n", "g.yaml");
  try {
    n.getList<double>("gains");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("g.yaml:5: gains[2]: expected a number, got 'x'"),
              std::string::npos)
        << e.what();
  }
}

TEST(ConfigMore, DuplicateKeyIsAnError) {
  const Node n = Node::loadString("length: 10\nwidth: 5\nlength: 20\n", "d.yaml");
  n.get<double>("length");
  n.get<double>("width");
  try {
    n.rejectUnknownKeys();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "d.yaml:3: length: duplicate key");
  }
}

TEST(ConfigMore, KeyWithoutValueIsNotSilentlyDefaulted) {
  const Node n = Node::loadString("noise:\ncamera:\n", "n.yaml");
  EXPECT_THROW(n.getOr<double>("noise", 0.5), Error);
  EXPECT_THROW(n.childIf("camera"), Error);
  EXPECT_DOUBLE_EQ(n.getOr<double>("absent", 0.5), 0.5);
  EXPECT_FALSE(n.childIf("absent_section").has_value());
}

TEST(ConfigMore, SectionReadThroughTwoChildCallsCountsAllKeys) {
  const Node n = Node::loadString("r:\n  a: 1\n  b: 2\n", "r.yaml");
  n.child("r").get<int>("a");
  n.child("r").get<int>("b");
  EXPECT_NO_THROW(n.child("r").rejectUnknownKeys());
}

TEST(ConfigMore, EmptyFileIsNamed) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("fieldline_empty_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(path) << "# nothing\n";
  try {
    Node::loadFile(path.string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ": file is empty");
  }
  std::filesystem::remove(path);
}

}  // namespace config_test
}  // namespace fieldline::config
