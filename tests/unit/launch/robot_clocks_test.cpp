#include <gtest/gtest.h>

#include <cstdlib>

#include "tools/launch/plan.hpp"
#include "tools/launch/robot_clocks.hpp"

namespace fieldline::launch {
namespace robot_clocks_test {

constexpr Utime kReference = 1'750'000'000'000'000;

const char* const kFile = R"(processes:
  - {name: world_sim, executable: fieldline-world-sim, robots: sim}
  - {name: fusion, executable: fieldline-fusion, robots: all, env: {FIELDLINE_CLOCK_DRIFT_PPM: "7"}}
  - {name: camera, executable: fieldline-camera, robots: all}
robots:
  - {id: 1, clock: {offset_s: 0.312, drift_ppm: 38}}
  - {id: 2, clock: {offset_s: -0.447, drift_ppm: -21.5}}
)";

TEST(RobotClocks, EveryProcessOfARobotGetsItsClock) {
  setenv(kClockReferenceVariable, std::to_string(kReference).c_str(), 1);
  const LaunchFile file = parseLaunchFile(config::Node::loadString(kFile, "team.yaml"));
  unsetenv(kClockReferenceVariable);
  ASSERT_EQ(file.clocks.by_robot.size(), 2u);
  EXPECT_EQ(file.clocks.of(1).offset_us, 312'000);
  EXPECT_EQ(file.clocks.of(2).drift_ppm, -21.5);
  EXPECT_EQ(file.clocks.of(2).reference_us, kReference);
  EXPECT_EQ(file.clocks.of(3).offset_us, 0);  // not listed: the true clock

  const LaunchPlan plan = planLaunch(file, 3, [](const std::string& exe) { return "/bin/" + exe; });
  for (const LaunchInstance& i : plan.instances) {
    SCOPED_TRACE(i.label());
    if (i.robot == kSimRobot || i.robot == 3) {
      // The simulator keeps the true time, and so does a robot without a clock.
      EXPECT_FALSE(i.env.contains(kClockOffsetVariable));
      continue;
    }
    const ClockError e = file.clocks.of(i.robot);
    EXPECT_EQ(i.env.at(kClockOffsetVariable), std::to_string(e.offset_us));
    EXPECT_EQ(i.env.at(kClockReferenceVariable), std::to_string(kReference));
    // An entry's own env wins over the robot's clock.
    EXPECT_EQ(i.env.at(kClockDriftVariable),
              i.name == "fusion" ? "7" : (i.robot == 1 ? "38" : "-21.5"));
  }
}

TEST(RobotClocks, BadEntriesNameTheKey) {
  const auto parse = [](const std::string& robots) {
    return parseRobotClocks(config::Node::loadString("robots:\n" + robots, "team.yaml"),
                            kReference);
  };
  EXPECT_NO_THROW(parse("  - {id: 6}\n"));
  EXPECT_THROW(parse("  - {id: 1, clock: {offset_s: 1.5}}\n"), config::Error);
  EXPECT_THROW(parse("  - {id: 1, clock: {drift_ppm: 500}}\n"), config::Error);
  EXPECT_THROW(parse("  - {id: 1, clock: {offset: 0.1}}\n"), config::Error);
  EXPECT_THROW(parse("  - {id: 0}\n"), config::Error);
  EXPECT_THROW(parse("  - {id: 1}\n  - {id: 1}\n"), config::Error);
  try {
    parse("  - {id: 2, clock: {offset_s: 0.1, drift_ppm: 300}}\n");
    FAIL() << "no error";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("drift_ppm"), std::string::npos) << e.what();
  }
}

TEST(RobotClocks, TheEnvironmentCarriesTheClock) {
  EXPECT_TRUE(clockEnvironment(ClockError{}).empty());
  const auto env = clockEnvironment(ClockError{-28'000, -33.0, kReference});
  EXPECT_EQ(env.at(kClockOffsetVariable), "-28000");
  EXPECT_EQ(env.at(kClockDriftVariable), "-33");
  setenv(kClockReferenceVariable, "soon", 1);
  EXPECT_THROW(clockReferenceNow(), config::Error);
  unsetenv(kClockReferenceVariable);
  EXPECT_GT(clockReferenceNow(), kReference - 100'000'000'000'000);
}

TEST(ClockControl, ReadsOneRobotALineWithComments) {
  const auto offsets = parseClockControl("# steps\n1 2000000   # ahead\n\n  3 -1500000\n", "cc");
  ASSERT_EQ(offsets.size(), 2u);
  EXPECT_EQ(offsets.at(1), 2'000'000);
  EXPECT_EQ(offsets.at(3), -1'500'000);
  EXPECT_TRUE(parseClockControl("", "cc").empty());
}

TEST(ClockControl, RefusesABadLineNamingIt) {
  const auto message = [](const std::string& text) {
    try {
      parseClockControl(text, "cc");
    } catch (const config::Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("1 0\n2\n").find("cc:2: '2' is not two numbers"), std::string::npos);
  EXPECT_NE(message("1 2 3\n").find("cc:1:"), std::string::npos);
  EXPECT_NE(message("0 100\n").find("robot '0' is not a robot number"), std::string::npos);
  EXPECT_NE(message("1 2.5\n").find("offset '2.5'"), std::string::npos);
  EXPECT_NE(message("1 10000001\n").find("within +-10 s"), std::string::npos);
  EXPECT_NE(message("1 5\n1 6\n").find("cc:2: robot 1 is listed twice"), std::string::npos);
}

}  // namespace robot_clocks_test
}  // namespace fieldline::launch
