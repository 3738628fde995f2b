#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "common/config/config.hpp"
#include "common/field/field_model.hpp"

namespace fieldline::field {
namespace field_config_test {

// A valid preset; tests replace one line to break it. Line numbers are noted for the messages.
const std::string kValid =
    "name: test\n"                            // 1
    "dimensions_measured_to: line_centres\n"  // 2
    "length: 12.0\n"                          // 3
    "width: 6.0\n"                            // 4
    "line_width: 0.05\n"                      // 5
    "border_width: 1.0\n"                     // 6
    "centre_circle_radius: 1.0\n"             // 7
    "corner_arc_radius: 0.4\n"                // 8
    "penalty_area:\n"                         // 9
    "  depth: 1.5\n"                          // 10
    "  width: 5.0\n"                          // 11
    "goal_area:\n"                            // 12
    "  depth: 0.5\n"                          // 13
    "  width: 3.0\n"                          // 14
    "goals:\n"                                // 15
    "  width: 2.0\n"                          // 16
    "  depth: 0.5\n"                          // 17
    "  height: 1.0\n"                         // 18
    "  own_colour: blue\n"                    // 19
    "  opponent_colour: yellow\n";            // 20

std::string replaced(const std::string& from, const std::string& to) {
  std::string text = kValid;
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// The config::Error message for loading `text`, or "" if it loaded.
std::string loadError(const std::string& text) {
  try {
    loadFieldModel(config::Node::loadString(text, "test.yaml"));
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(FieldConfig, ValidTextLoads) {
  const FieldModel m = loadFieldModel(config::Node::loadString(kValid, "test.yaml"));
  EXPECT_EQ(m.name(), "test");
  // Boundary line width defaults to the line width.
  EXPECT_DOUBLE_EQ(m.boundaryLineWidth(), 0.05);
  EXPECT_TRUE(m.penaltyMarks().empty());
}

TEST(FieldConfig, MissingKeyNamesFileLineAndKey) {
  EXPECT_EQ(loadError(replaced("  depth: 0.5\n  width: 3.0\n", "  width: 3.0\n")),
            "test.yaml:13: goal_area.depth: missing required key");
  EXPECT_EQ(loadError(replaced("width: 6.0\n", "")), "test.yaml:1: width: missing required key");
}

TEST(FieldConfig, UnknownKeyNamesFileLineAndKey) {
  const std::string error = loadError(replaced("length: 12.0\n", "length: 12.0\nlenght: 12.0\n"));
  EXPECT_NE(error.find("test.yaml:4: lenght: unknown key"), std::string::npos) << error;
  const std::string nested =
      loadError(replaced("  own_colour: blue\n", "  own_colour: blue\n  colour: red\n"));
  EXPECT_NE(nested.find("test.yaml:20: goals.colour: unknown key"), std::string::npos) << nested;
}

TEST(FieldConfig, OutOfRangeNamesFileLineAndKey) {
  EXPECT_EQ(loadError(replaced("width: 6.0\n", "width: 500\n")),
            "test.yaml:4: width: value 500 out of range [1, 100]");
  EXPECT_EQ(loadError(replaced("  height: 1.0\n", "  height: -1\n")),
            "test.yaml:18: goals.height: value -1 out of range [0.05, 5]");
  const std::string nan = loadError(replaced("length: 12.0\n", "length: .nan\n"));
  EXPECT_NE(nan.find("test.yaml:3: length: must be a finite number"), std::string::npos) << nan;
}

TEST(FieldConfig, WrongTypeAndBadChoice) {
  const std::string type = loadError(replaced("length: 12.0\n", "length: twelve\n"));
  EXPECT_NE(type.find("test.yaml:3: length: expected a number"), std::string::npos) << type;
  const std::string choice = loadError(replaced("line_centres", "middle_of_nowhere"));
  EXPECT_NE(choice.find("test.yaml:2: dimensions_measured_to: 'middle_of_nowhere' is not one of"),
            std::string::npos)
      << choice;
  const std::string colour = loadError(replaced("own_colour: blue", "own_colour: green"));
  EXPECT_NE(colour.find("test.yaml:19: goals.own_colour"), std::string::npos) << colour;
}

TEST(FieldConfig, InconsistentDimensionsNameTheKey) {
  const std::string wide = loadError(replaced("  width: 3.0\n", "  width: 5.5\n"));
  EXPECT_NE(wide.find("test.yaml:14: goal_area.width: must be less than the penalty area width"),
            std::string::npos)
      << wide;
  const std::string deep = loadError(replaced("  depth: 1.5\n", "  depth: 5.5\n"));
  EXPECT_NE(deep.find("test.yaml:10: penalty_area.depth: penalty area reaches the centre circle"),
            std::string::npos)
      << deep;
  const std::string corner =
      loadError(replaced("corner_arc_radius: 0.4", "corner_arc_radius: 0.7"));
  EXPECT_NE(corner.find("test.yaml:8: corner_arc_radius:"), std::string::npos) << corner;
}

TEST(FieldConfig, PenaltyMarksSectionIsChecked) {
  const std::string marks = "penalty_marks:\n  distance: 3.0\n  diameter: 0.1\n";
  const FieldModel m = loadFieldModel(config::Node::loadString(kValid + marks, "test.yaml"));
  ASSERT_EQ(m.penaltyMarks().size(), 2u);
  EXPECT_DOUBLE_EQ(m.penaltyMarks()[1].x(), 3.0);
  const std::string far = "penalty_marks:\n  distance: 7.0\n  diameter: 0.1\n";
  EXPECT_NE(loadError(kValid + far).find("test.yaml:22: penalty_marks.distance:"),
            std::string::npos);
  const std::string extra = "penalty_marks:\n  distance: 3.0\n  diameter: 0.1\n  colour: 1\n";
  EXPECT_NE(loadError(kValid + extra).find("test.yaml:24: penalty_marks.colour: unknown key"),
            std::string::npos);
}

TEST(FieldConfig, OuterEdgesAndLineCentresDescribeTheSameField) {
  // The same field measured to the outer edges of 0.1 m lines.
  std::string outer = replaced("line_centres", "outer_edges");
  outer.replace(outer.find("line_width: 0.05"), 16, "line_width: 0.1");
  outer.replace(outer.find("length: 12.0"), 12, "length: 12.1");
  outer.replace(outer.find("width: 6.0"), 10, "width: 6.1");
  outer.replace(outer.find("centre_circle_radius: 1.0"), 25, "centre_circle_radius: 1.05");
  outer.replace(outer.find("corner_arc_radius: 0.4"), 22, "corner_arc_radius: 0.45");
  outer.replace(outer.find("  depth: 1.5\n  width: 5.0"), 25, "  depth: 1.6\n  width: 5.1");
  outer.replace(outer.find("  depth: 0.5\n  width: 3.0"), 25, "  depth: 0.6\n  width: 3.1");
  const FieldModel a = loadFieldModel(config::Node::loadString(kValid, "centres.yaml"));
  const FieldModel b = loadFieldModel(config::Node::loadString(outer, "outer.yaml"));
  ASSERT_EQ(a.segments().size(), b.segments().size());
  for (std::size_t i = 0; i < a.segments().size(); ++i) {
    EXPECT_NEAR((a.segments()[i].a - b.segments()[i].a).norm(), 0.0, 1e-9) << i;
    EXPECT_NEAR((a.segments()[i].b - b.segments()[i].b).norm(), 0.0, 1e-9) << i;
  }
  for (std::size_t i = 0; i < a.arcs().size(); ++i) {
    EXPECT_NEAR(a.arcs()[i].radius, b.arcs()[i].radius, 1e-9) << i;
  }
}

TEST(FieldConfig, CircleArcsAndAreasAreOptional) {
  // A lab field of any size: only the rectangle and the halfway line.
  const std::string bare =
      "name: bare\ndimensions_measured_to: outer_edges\nlength: 4.0\nwidth: 3.0\n"
      "line_width: 0.05\nborder_width: 0.3\n"
      "goals:\n  width: 1.0\n  depth: 0.3\n  height: 0.5\n"
      "  own_colour: white\n  opponent_colour: white\n";
  const FieldModel m = loadFieldModel(config::Node::loadString(bare, "bare.yaml"));
  EXPECT_FALSE(m.hasCentreCircle());
  EXPECT_FALSE(m.hasCornerArcs());
  EXPECT_FALSE(m.hasPenaltyAreas());
  EXPECT_FALSE(m.hasGoalAreas());
  EXPECT_FALSE(m.hasPenaltyArcs());
  EXPECT_EQ(m.segments().size(), 5u);
  EXPECT_TRUE(m.arcs().empty());
  EXPECT_NEAR(m.length(), 3.95, 1e-12);
  // The centre is 1.475 m from the nearest line (the touch lines), not on a circle.
  EXPECT_NEAR(m.distance(Vec2(0.5, 0.0)), 0.5, 1e-12);
  EXPECT_NEAR(m.distance(Vec2(1.0, 0.0)), 0.975, 1e-12);

  // The seed's field without its corner arcs and circle: 17 segments, no arc.
  std::string no_arcs = replaced("centre_circle_radius: 1.0\n", "");
  no_arcs.replace(no_arcs.find("corner_arc_radius: 0.4\n"), 23, "");
  const FieldModel n = loadFieldModel(config::Node::loadString(no_arcs, "test.yaml"));
  EXPECT_EQ(n.segments().size(), 17u);
  EXPECT_TRUE(n.arcs().empty());
  // Only a goal area: 5 + 6 segments.
  std::string goal_only = replaced("penalty_area:\n  depth: 1.5\n  width: 5.0\n", "");
  const FieldModel g = loadFieldModel(config::Node::loadString(goal_only, "test.yaml"));
  EXPECT_TRUE(g.hasGoalAreas());
  EXPECT_FALSE(g.hasPenaltyAreas());
  EXPECT_EQ(g.segments().size(), 11u);
}

TEST(FieldConfig, PenaltyArcIsTheDInFrontOfThePenaltyArea) {
  // Centre 1.0 m from the goal line, radius 0.8 m, front line at 1.5 m: the D bulges 0.3 m out.
  const std::string d = "penalty_arc:\n  centre_distance: 1.0\n  radius: 0.8\n";
  const FieldModel m = loadFieldModel(config::Node::loadString(kValid + d, "test.yaml"));
  ASSERT_TRUE(m.hasPenaltyArcs());
  ASSERT_EQ(m.arcs().size(), 7u);
  const LineArc& own = m.arcs()[5];
  const LineArc& opponent = m.arcs()[6];
  EXPECT_NEAR((own.centre - Vec2(-5.0, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((opponent.centre - Vec2(5.0, 0.0)).norm(), 0.0, 1e-12);
  // Both ends on the front line (x = -4.5), inside the area; the apex 0.3 m beyond it.
  const double half_chord = std::sqrt(0.8 * 0.8 - 0.5 * 0.5);
  EXPECT_NEAR((own.startPoint() - Vec2(-4.5, -half_chord)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((own.endPoint() - Vec2(-4.5, half_chord)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((opponent.startPoint() - Vec2(4.5, half_chord)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(m.distance(Vec2(-4.2, 0.0)), 0.0, 1e-12);
  EXPECT_NEAR(m.distance(Vec2(4.0, 0.0)), 0.2, 1e-12);
  // Inside the area the arc is not painted: the front line is nearest.
  EXPECT_NEAR(m.distance(Vec2(-4.7, 0.0)), 0.2, 1e-12);
  // Its centre defaults to the penalty mark.
  const std::string marks = "penalty_marks:\n  distance: 1.2\n  diameter: 0.1\n";
  const FieldModel k = loadFieldModel(
      config::Node::loadString(kValid + marks + "penalty_arc:\n  radius: 0.5\n", "test.yaml"));
  EXPECT_NEAR(k.arcs()[5].centre.x(), -4.8, 1e-12);

  EXPECT_NE(loadError(kValid + "penalty_arc:\n  radius: 0.5\n")
                .find("test.yaml:22: penalty_arc.centre_distance: required"),
            std::string::npos);
  // Too small to reach beyond the front line, and one that meets it beyond the area's sides.
  EXPECT_NE(loadError(kValid + "penalty_arc:\n  centre_distance: 1.0\n  radius: 0.4\n")
                .find("test.yaml:23: penalty_arc.radius: the arc does not reach beyond"),
            std::string::npos);
  EXPECT_NE(loadError(kValid + "penalty_arc:\n  centre_distance: 1.0\n  radius: 2.9\n")
                .find("penalty_arc.radius: the arc meets the front line outside"),
            std::string::npos);
  const std::string no_area = replaced("penalty_area:\n  depth: 1.5\n  width: 5.0\n", "");
  EXPECT_NE(loadError(no_area + "penalty_arc:\n  centre_distance: 1.0\n  radius: 0.8\n")
                .find("penalty_arc.radius: a penalty arc needs a penalty area"),
            std::string::npos);
}

TEST(FieldConfig, PresetByPathAndMissingFile) {
  const FieldModel m = loadFieldPreset(config::projectRoot() + "/config/field/msl.yaml");
  EXPECT_EQ(m.name(), "msl");
  EXPECT_THROW(loadFieldPreset("no_such_field"), config::Error);
}

}  // namespace field_config_test
}  // namespace fieldline::field
