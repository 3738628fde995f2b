// The viewer's state document: exact numbers, null for what has not arrived, escaped strings,
// stale statuses, and the field's elements.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "common/field/field_model.hpp"
#include "tools/viewer/team_view.hpp"

namespace fieldline::viewer {
namespace team_view_test {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(TeamView, RobotStateNumbersRoundTripAndOtherRobotsAreNull) {
  TeamView team({1, 3});
  robot_state_t m{};
  m.header.utime = 1'700'000'000'000'000;
  m.header.robot_id = 3;
  m.header.seq = 41;
  m.x = 1.0 / 3.0;
  m.y = -0.1;
  m.status = robot_state_t::STATUS_TRACKING;
  team.bus(3).robot_state = Received<robot_state_t>{m, m.header.utime + 250'000};
  const std::string json = team.toJson(m.header.utime + 500'000, kMicrosPerSecond);
  EXPECT_TRUE(contains(json, "{\"id\":1,\"bus\":\"\",\"robot_state\":null")) << json;
  EXPECT_TRUE(contains(json, "\"x\":0.3333333333333333,\"y\":-0.1,")) << json;
  EXPECT_TRUE(contains(json, "\"seq\":41,\"robot_id\":3,\"age_s\":0.25,")) << json;
  EXPECT_TRUE(contains(json, "\"status\":2")) << json;
  EXPECT_TRUE(contains(json, "\"sim\":{\"bus\":\"\",\"world\":null,\"processes\":[]}")) << json;
}

TEST(TeamView, RejectsRobotsOutsideTheTeamAndTwice) {
  EXPECT_THROW(TeamView({0}), std::invalid_argument);
  EXPECT_THROW(TeamView({7}), std::invalid_argument);
  EXPECT_THROW(TeamView({2, 2}), std::invalid_argument);
  TeamView team({2});
  EXPECT_THROW(team.bus(4), std::out_of_range);
}

TEST(TeamView, StatusIsStaleAfterItsTimeoutAndStringsAreEscaped) {
  TeamView team({1});
  service_status_t s{};
  s.process = "cam\"era\\\n\x01\xff";
  s.last_error = "bad";
  team.bus(1).statuses[{"camera", 1}] = {s, 1'000'000};
  const std::string fresh = team.toJson(1'500'000, 1'000'000);
  EXPECT_TRUE(contains(fresh, "\"process\":\"cam\\\"era\\\\\\n\\u0001\\ufffd\"")) << fresh;
  EXPECT_TRUE(contains(fresh, "\"stale\":false")) << fresh;
  EXPECT_TRUE(contains(team.toJson(2'500'000, 1'000'000), "\"stale\":true"));
}

TEST(FieldJson, HasEveryLineArcGoalAndMark) {
  const field::FieldModel model = field::loadFieldPreset("msl");
  const std::string json = fieldJson(model);
  std::size_t widths = 0;
  for (std::size_t at = json.find("\"width\":"); at != std::string::npos;
       at = json.find("\"width\":", at + 1))
    ++widths;
  // One per segment, arc and goal, plus the field's own width.
  EXPECT_EQ(widths, model.segments().size() + model.arcs().size() + model.goals().size() + 1);
  EXPECT_TRUE(contains(json, "\"name\":\"msl\"")) << json;
  EXPECT_EQ(contains(json, "\"penalty_marks\":[]"), model.penaltyMarks().empty()) << json;
}

}  // namespace team_view_test
}  // namespace fieldline::viewer
