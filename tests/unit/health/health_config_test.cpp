// Issue 13 finding 8: configuration errors that say what was meant. A misspelt optional key names
// the closest valid key and every valid one; a misspelt required key is reported as the unknown
// key it is together with the missing one; a camera preset naming a colour table that does not
// exist fails when the preset is read. Finding 6: a multicast group that is not one fails when
// the launch file is read (so at --dry-run), not in every child at run time.
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "common/camera/mirror_model.hpp"
#include "common/config/closest.hpp"
#include "common/config/config.hpp"
#include "tools/launch/launch_file.hpp"

namespace fieldline {
namespace health_config_test {

std::string launchError(const std::string& text) {
  try {
    launch::parseLaunchFile(config::Node::loadString(text, "team.yaml"));
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(HealthConfig, MisspeltOptionalKeySaysDidYouMeanAndListsEveryValidKey) {
  const std::string e = launchError(
      "defaults:\n  restrat: always\nprocesses:\n  - {name: a, executable: b, robots: 1}\n");
  EXPECT_NE(e.find("team.yaml:2: defaults.restrat: unknown key (did you mean restart?"),
            std::string::npos)
      << e;
  // Before: "(expected one of: backoff, bus, robots, stop_grace_s)", restart missing.
  for (const char* key : {"backoff", "bus", "crash_loop", "restart", "robots", "stop_grace_s"}) {
    EXPECT_NE(e.find(std::string(key) + (std::string(key) == "stop_grace_s" ? ")" : ",")),
              std::string::npos)
        << key << " not listed: " << e;
  }
  // Same for the keys of a process entry that are read only when present.
  const std::string p =
      launchError("processes:\n  - {name: a, executable: b, robots: 1, main_chanel: ODOMETRY}\n");
  EXPECT_NE(p.find("did you mean main_channel?"), std::string::npos) << p;
  for (const char* key :
       {"args", "env", "executable", "main_channel", "name", "optional", "restart", "robots"}) {
    EXPECT_NE(p.find(key), std::string::npos) << key << " not listed: " << p;
  }
}

TEST(HealthConfig, MisspeltRequiredKeyIsNamedAsUnknownAndAsMissing) {
  const std::string e = launchError("processes:\n  - name: a\n    executabel: b\n    robots: 1\n");
  // Before: only "processes[0].executable: missing required key".
  EXPECT_NE(e.find("team.yaml:3: processes[0].executabel: unknown key (did you mean executable?)"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("processes[0].executable: missing required key"), std::string::npos) << e;
  // A key that is simply absent is still just missing.
  const std::string absent = launchError("processes:\n  - name: a\n    robots: 1\n");
  EXPECT_EQ(absent.find("unknown key"), std::string::npos) << absent;
  EXPECT_NE(absent.find("processes[0].executable: missing required key"), std::string::npos);
}

TEST(HealthConfig, ClosestMatchOnlySuggestsPlausibleMisspellings) {
  EXPECT_EQ(config::editDistance("restrat", "restart"), 1U);
  EXPECT_EQ(config::closestMatch("restrat", {"robots", "restart", "bus"}), "restart");
  EXPECT_EQ(config::closestMatch("fieldline-camrea", {"fieldline-camera", "fieldline-fusion"}),
            "fieldline-camera");
  EXPECT_EQ(config::closestMatch("colour", {"robots", "restart"}), "");
  EXPECT_EQ(config::closestMatch("bus", {"bus"}), "");  // the word itself is no suggestion
}

TEST(HealthConfig, ColourTablePresetIsCheckedWhenTheCameraPresetIsRead) {
  const config::Node root = config::Node::loadFile(config::resolvePreset("camera", "omni_sim"));
  std::string text;
  {
    std::ifstream in(root.file());
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string from = "colour_table: colours_sim";
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos) << "omni_sim.yaml names no colours_sim";
  text.replace(at, from.size(), "colour_table: colours_nope");
  std::string error;
  try {
    (void)camera::loadCameraModel(config::Node::loadString(text, "cam.yaml"));
  } catch (const config::Error& e) {
    error = e.what();
  }
  // Before: accepted; region tracking failed later when it loaded the table.
  EXPECT_NE(error.find("cam.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("colour_table: colour table preset 'colours_nope' does not load"),
            std::string::npos)
      << error;
  EXPECT_NO_THROW((void)camera::loadCameraPreset("omni_sim"));
}

TEST(HealthConfig, MulticastGroupIsCheckedWhenTheLaunchFileIsRead) {
  const auto with_group = [](const std::string& group) {
    return launchError("defaults:\n  bus: {group: " + group +
                       "}\nprocesses:\n  - {name: a, executable: b, robots: 1}\n");
  };
  // Before: passed --dry-run; every process then exited 3 ("run scripts/setup").
  EXPECT_NE(
      with_group("239.255.76.999").find("defaults.bus.group: '239.255.76.999' is not an IPv4"),
      std::string::npos)
      << with_group("239.255.76.999");
  EXPECT_NE(with_group("10.0.0.1").find("is not a multicast group"), std::string::npos);
  EXPECT_NE(with_group("\"\"").find("must not be empty"), std::string::npos);
  EXPECT_EQ(with_group("239.255.76.67"), "");
  EXPECT_EQ(launch::checkMulticastGroup("224.0.0.251"), "");
  EXPECT_NE(launch::checkMulticastGroup("240.0.0.1"), "");
}

}  // namespace health_config_test
}  // namespace fieldline
