#include "common/field/field_model.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace fieldline::field {
namespace field_model_test {

constexpr double kPi = std::numbers::pi;
constexpr double kTol = 1e-9;

void expectNear(const Vec2& actual, const Vec2& expected, double tol = kTol) {
  EXPECT_NEAR(actual.x(), expected.x(), tol) << "y: " << actual.y() << " vs " << expected.y();
  EXPECT_NEAR(actual.y(), expected.y(), tol) << "x: " << actual.x() << " vs " << expected.x();
}

bool sameSegment(const LineSegment& s, const Vec2& a, const Vec2& b) {
  const double tol = 1e-9;
  return ((s.a - a).norm() < tol && (s.b - b).norm() < tol) ||
         ((s.a - b).norm() < tol && (s.b - a).norm() < tol);
}

bool hasSegment(const FieldModel& m, const Vec2& a, const Vec2& b) {
  return std::any_of(m.segments().begin(), m.segments().end(),
                     [&](const LineSegment& s) { return sameSegment(s, a, b); });
}

// Every preset in config/field (the names of its YAML files).
std::vector<std::string> allPresets() {
  std::vector<std::string> names;
  for (const auto& entry :
       std::filesystem::directory_iterator(config::projectRoot() + "/config/field")) {
    if (entry.path().extension() == ".yaml") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

TEST(SeedPresets, HaveTheSeedsSeventeenSegmentsAndFiveArcs) {
  for (const char* name : {"fu2004", "msl"}) {
    const FieldModel m = loadFieldPreset(name);
    EXPECT_EQ(m.name(), name);
    EXPECT_EQ(m.segments().size(), 17u);
    EXPECT_EQ(m.arcs().size(), 5u);
    EXPECT_EQ(m.goals().size(), 2u);
    // Four quarter circles and one full circle.
    for (int i = 0; i < 4; ++i)
      EXPECT_NEAR(m.arcs()[i].sweep, kPi / 2, kTol);
    EXPECT_NEAR(m.arcs()[4].sweep, 2 * kPi, kTol);
  }
}

class Presets : public ::testing::TestWithParam<std::string> {};

TEST_P(Presets, NameIsTheFileNameAndElementsFollowTheOptionalParts) {
  const FieldModel m = loadFieldPreset(GetParam());
  EXPECT_EQ(m.name(), GetParam());
  EXPECT_EQ(m.goals().size(), 2u);
  const std::size_t segments = 5 + (m.hasPenaltyAreas() ? 6 : 0) + (m.hasGoalAreas() ? 6 : 0);
  const std::size_t arcs =
      (m.hasCornerArcs() ? 4 : 0) + (m.hasCentreCircle() ? 1 : 0) + (m.hasPenaltyArcs() ? 2 : 0);
  EXPECT_EQ(m.segments().size(), segments);
  EXPECT_EQ(m.arcs().size(), arcs);
  // Every line lies on the carpet inside the outer edges of the touch and goal lines.
  for (const Vec2& p : m.sampleLines(0.05))
    EXPECT_TRUE(m.insideLines(p, 1e-9)) << p.transpose();
}

TEST_P(Presets, IsSymmetricUnderBothMirrors) {
  const FieldModel m = loadFieldPreset(GetParam());
  for (const auto& s : m.segments()) {
    EXPECT_TRUE(hasSegment(m, Vec2(-s.a.x(), s.a.y()), Vec2(-s.b.x(), s.b.y())));
    EXPECT_TRUE(hasSegment(m, Vec2(s.a.x(), -s.a.y()), Vec2(s.b.x(), -s.b.y())));
  }
  std::mt19937 rng(2004);
  const Vec2 half = m.carpetHalfExtent();
  std::uniform_real_distribution<double> x(-half.x(), half.x());
  std::uniform_real_distribution<double> y(-half.y(), half.y());
  for (int k = 0; k < 2000; ++k) {
    const Vec2 p(x(rng), y(rng));
    const double d = m.distance(p);
    ASSERT_NEAR(m.distance(Vec2(-p.x(), p.y())), d, 1e-9);
    ASSERT_NEAR(m.distance(Vec2(p.x(), -p.y())), d, 1e-9);
    ASSERT_NEAR(m.distance(-p), d, 1e-9);
  }
}

TEST_P(Presets, ClosestPointMatchesDenseSamplingAndLiesOnALine) {
  const FieldModel m = loadFieldPreset(GetParam());
  const double step = 0.002;
  const std::vector<Vec2> dense = m.sampleLines(step);
  std::mt19937 rng(17);
  const Vec2 half = m.carpetHalfExtent();
  std::uniform_real_distribution<double> x(-half.x(), half.x());
  std::uniform_real_distribution<double> y(-half.y(), half.y());
  for (int k = 0; k < 300; ++k) {
    const Vec2 p(x(rng), y(rng));
    const auto closest = m.closestPoint(p);
    double brute = std::numeric_limits<double>::infinity();
    for (const Vec2& q : dense)
      brute = std::min(brute, (p - q).norm());
    // The dense samples are at most step/2 from any line point.
    ASSERT_LE(closest.distance, brute + 1e-12);
    ASSERT_GE(closest.distance, brute - step / 2 - 1e-12);
    ASSERT_NEAR((closest.point - p).norm(), closest.distance, 1e-12);
    ASSERT_LT(m.distance(closest.point), 1e-9);
  }
}

TEST_P(Presets, SampleLinesSpacingAndCoverage) {
  const FieldModel m = loadFieldPreset(GetParam());
  const double step = 0.1;
  const std::vector<Vec2> points = m.sampleLines(step);
  double total_length = 0.0;
  for (const auto& s : m.segments())
    total_length += s.length();
  for (const auto& a : m.arcs())
    total_length += a.radius * a.sweep;
  // At least one point per step of line, and not wastefully many.
  EXPECT_GE(points.size(), static_cast<std::size_t>(total_length / step));
  EXPECT_LE(points.size(), static_cast<std::size_t>(total_length / step) +
                               3 * (m.segments().size() + m.arcs().size()));
  for (const Vec2& p : points)
    ASSERT_LT(m.distance(p), 1e-9);
  // Every point of every line is within step/2 of a sample.
  for (const Vec2& q : m.sampleLines(0.01)) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vec2& p : points)
      nearest = std::min(nearest, (p - q).norm());
    ASSERT_LE(nearest, step / 2 + 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(Field, Presets, ::testing::ValuesIn(allPresets()));

TEST(Fu2004, ElementsMatchTable44) {
  // w = 600, h = 300, p = s = 150, g = 50, q = 250, r = 100, a = 40 cm.
  const FieldModel m = loadFieldPreset("fu2004");
  EXPECT_DOUBLE_EQ(m.length(), 12.0);
  EXPECT_DOUBLE_EQ(m.width(), 6.0);
  EXPECT_DOUBLE_EQ(m.lineWidth(), 0.05);
  EXPECT_DOUBLE_EQ(m.boundaryLineWidth(), 0.125);
  const auto& s = m.segments();
  EXPECT_TRUE(sameSegment(s[0], Vec2(-6, 3), Vec2(6, 3)));
  EXPECT_TRUE(sameSegment(s[1], Vec2(-6, -3), Vec2(6, -3)));
  EXPECT_TRUE(sameSegment(s[2], Vec2(-6, -3), Vec2(-6, 3)));
  EXPECT_TRUE(sameSegment(s[3], Vec2(6, -3), Vec2(6, 3)));
  EXPECT_TRUE(sameSegment(s[4], Vec2(0, -3), Vec2(0, 3)));
  EXPECT_TRUE(sameSegment(s[5], Vec2(-4.5, -2.5), Vec2(-4.5, 2.5)));
  EXPECT_TRUE(sameSegment(s[6], Vec2(4.5, -2.5), Vec2(4.5, 2.5)));
  EXPECT_TRUE(sameSegment(s[7], Vec2(-5.5, -1.5), Vec2(-5.5, 1.5)));
  EXPECT_TRUE(sameSegment(s[8], Vec2(5.5, -1.5), Vec2(5.5, 1.5)));
  EXPECT_TRUE(sameSegment(s[9], Vec2(-6, 2.5), Vec2(-4.5, 2.5)));
  EXPECT_TRUE(sameSegment(s[12], Vec2(4.5, -2.5), Vec2(6, -2.5)));
  EXPECT_TRUE(sameSegment(s[13], Vec2(-6, 1.5), Vec2(-5.5, 1.5)));
  EXPECT_TRUE(sameSegment(s[16], Vec2(5.5, -1.5), Vec2(6, -1.5)));
  EXPECT_DOUBLE_EQ(s[0].width, 0.125);
  EXPECT_DOUBLE_EQ(s[4].width, 0.05);
  // Corner arc at the (-x, +y) corner runs from the goal line to the touch line.
  const LineArc& corner = m.arcs()[0];
  expectNear(corner.centre, Vec2(-6, 3));
  EXPECT_DOUBLE_EQ(corner.radius, 0.4);
  expectNear(corner.startPoint(), Vec2(-6, 2.6));
  expectNear(corner.endPoint(), Vec2(-5.6, 3));
  expectNear(m.arcs()[2].startPoint(), Vec2(6, -2.6));
  expectNear(m.arcs()[4].centre, Vec2(0, 0));
  EXPECT_DOUBLE_EQ(m.arcs()[4].radius, 1.0);
  EXPECT_TRUE(m.penaltyMarks().empty());
  EXPECT_EQ(m.goals()[0].colour, GoalColour::kBlue);
  EXPECT_EQ(m.goals()[1].colour, GoalColour::kYellow);
  expectNear(m.goals()[1].mouth_centre, Vec2(6.0625, 0));
  expectNear(m.goals()[0].outward, Vec2(-1, 0));
  expectNear(m.carpetHalfExtent(), Vec2(7.0625, 4.0625));
}

TEST(Msl, RulebookOuterEdgesBecomeLineCentres) {
  const FieldModel m = loadFieldPreset("msl");
  const double half_line = 0.0625;
  EXPECT_DOUBLE_EQ(m.length(), 22.0 - 2 * half_line);
  EXPECT_DOUBLE_EQ(m.width(), 14.0 - 2 * half_line);
  // Outer edge of the goal line at x = 11, penalty front line's outer edge 2.25 m inside it.
  EXPECT_NEAR(m.segments()[6].a.x(), 11.0 - 2.25 + half_line, kTol);
  EXPECT_NEAR(m.segments()[8].a.x(), 11.0 - 0.75 + half_line, kTol);
  // Side lines' outer edges 6.9 / 2 and 3.9 / 2 from the axis.
  EXPECT_NEAR(m.segments()[9].a.y(), 3.45 - half_line, kTol);
  EXPECT_NEAR(m.segments()[13].a.y(), 1.95 - half_line, kTol);
  EXPECT_NEAR(m.arcs()[4].radius, 2.0 - half_line, kTol);
  EXPECT_NEAR(m.arcs()[0].radius, 0.75 - half_line, kTol);
  ASSERT_EQ(m.penaltyMarks().size(), 2u);
  expectNear(m.penaltyMarks()[0], Vec2(-11.0 + 3.6, 0));
  expectNear(m.penaltyMarks()[1], Vec2(11.0 - 3.6, 0));
  EXPECT_DOUBLE_EQ(m.dimensions().penalty_mark_diameter, 0.15);
  expectNear(m.goals()[1].mouth_centre, Vec2(11.0, 0));
  EXPECT_EQ(m.goals()[0].colour, GoalColour::kWhite);
  EXPECT_DOUBLE_EQ(m.goals()[1].width, 2.0);
  expectNear(m.carpetHalfExtent(), Vec2(12.0, 8.0));
  for (const auto& s : m.segments())
    EXPECT_DOUBLE_EQ(s.width, 0.125);
}

TEST(Distance, OnBesideAndFarFromSegments) {
  const FieldModel m = loadFieldPreset("fu2004");
  // On the touch line.
  auto c = m.closestPoint(Vec2(2.5, 3.0));
  EXPECT_NEAR(c.distance, 0.0, kTol);
  EXPECT_EQ(c.element, 0);
  EXPECT_FALSE(c.is_arc);
  // 0.2 m outside the touch line, and 0.2 m inside it.
  c = m.closestPoint(Vec2(2.5, 3.2));
  EXPECT_NEAR(c.distance, 0.2, kTol);
  expectNear(c.point, Vec2(2.5, 3.0));
  EXPECT_NEAR(m.distance(Vec2(2.5, 2.8)), 0.2, kTol);
  // 0.3 m in front of the opponent penalty area front line (x = 4.5).
  c = m.closestPoint(Vec2(4.2, 0.4));
  EXPECT_NEAR(c.distance, 0.3, kTol);
  EXPECT_EQ(c.element, 6);
  // Far outside: 4 m beyond the touch line.
  EXPECT_NEAR(m.distance(Vec2(1.5, 7.0)), 4.0, kTol);
  // Beyond the end of the goal area side line (-6..-5.5 at y = 1.5): its end at the goal line.
  c = m.closestPoint(Vec2(-6.3, 1.5));
  EXPECT_NEAR(c.distance, 0.3, kTol);
  // Off the field's corner: the corner point (-6, 3) itself.
  c = m.closestPoint(Vec2(-7.0, 4.0));
  EXPECT_NEAR(c.distance, std::sqrt(2.0), kTol);
  expectNear(c.point, Vec2(-6, 3));
}

TEST(Distance, InsideAndOutsideTheCentreCircle) {
  const FieldModel m = loadFieldPreset("fu2004");
  const Vec2 direction(std::cos(kPi / 6), std::sin(kPi / 6));
  // 0.2 m inside the circle at 30 degrees (the halfway line is 0.69 m away).
  auto c = m.closestPoint(0.8 * direction);
  EXPECT_NEAR(c.distance, 0.2, kTol);
  EXPECT_TRUE(c.is_arc);
  EXPECT_EQ(c.element, 4);
  expectNear(c.point, direction);
  // 0.3 m outside.
  c = m.closestPoint(1.3 * direction);
  EXPECT_NEAR(c.distance, 0.3, kTol);
  expectNear(c.point, direction);
  // The centre spot lies on the halfway line.
  EXPECT_NEAR(m.distance(Vec2(0, 0)), 0.0, kTol);
}

TEST(ArcClosestPoint, WithinBeyondEndsAndAtTheCentre) {
  // Radius 2 around (1, 1) from 30 to 120 degrees.
  const LineArc arc{Vec2(1, 1), 2.0, kPi / 6, kPi / 2, 0.1};
  const auto at = [](double degrees, double radius) -> Vec2 {
    const double a = degrees * kPi / 180;
    return Vec2(1, 1) + radius * Vec2(std::cos(a), std::sin(a));
  };
  expectNear(closestPointOnArc(arc, at(60, 3.0)), at(60, 2.0));
  expectNear(closestPointOnArc(arc, at(60, 0.5)), at(60, 2.0));
  expectNear(closestPointOnArc(arc, at(30, 2.5)), at(30, 2.0));
  // Beyond the end at 120 degrees: the point at 180 degrees on the circle is one chord of
  // 60 degrees (= the radius) from the end point.
  expectNear(closestPointOnArc(arc, at(180, 2.0)), arc.endPoint());
  EXPECT_NEAR((at(180, 2.0) - arc.endPoint()).norm(), 2.0, kTol);
  // Beyond the start (at -10 degrees, outside and inside the radius).
  expectNear(closestPointOnArc(arc, at(-10, 2.5)), arc.startPoint());
  expectNear(closestPointOnArc(arc, at(-10, 0.3)), arc.startPoint());
  // Behind the centre at 300 deg: 90 deg from the start (30), 180 deg from the end (120).
  expectNear(closestPointOnArc(arc, at(300, 1.0)), arc.startPoint());
  // At the centre every arc point is equally close.
  EXPECT_NEAR((closestPointOnArc(arc, Vec2(1, 1)) - Vec2(1, 1)).norm(), 2.0, kTol);
}

TEST(ArcClosestPoint, ArcAcrossThePlusMinusPiSeam) {
  // From 150 to 240 degrees.
  const LineArc arc{Vec2(0, 0), 1.0, 5 * kPi / 6, kPi / 2, 0.1};
  EXPECT_TRUE(arc.contains(kPi));
  EXPECT_TRUE(arc.contains(-170 * kPi / 180));
  EXPECT_TRUE(arc.contains(-2 * kPi / 3));
  EXPECT_FALSE(arc.contains(-110 * kPi / 180));
  EXPECT_FALSE(arc.contains(0.0));
  expectNear(closestPointOnArc(arc, Vec2(-3, -0.1)), Vec2(-3, -0.1).normalized());
  expectNear(closestPointOnArc(arc, Vec2(0.2, -3)), arc.endPoint());
}

TEST(SegmentClosestPoint, ClampsToEnds) {
  const LineSegment s{Vec2(0, 0), Vec2(2, 0), 0.1};
  expectNear(closestPointOnSegment(s, Vec2(1, 5)), Vec2(1, 0));
  expectNear(closestPointOnSegment(s, Vec2(-1, 1)), Vec2(0, 0));
  expectNear(closestPointOnSegment(s, Vec2(3, -1)), Vec2(2, 0));
  const LineSegment point{Vec2(1, 1), Vec2(1, 1), 0.1};
  expectNear(closestPointOnSegment(point, Vec2(4, 5)), Vec2(1, 1));
}

TEST(FieldModel, RejectsNonFiniteQueries) {
  const FieldModel m = loadFieldPreset("msl");
  EXPECT_THROW(m.closestPoint(Vec2(std::numeric_limits<double>::quiet_NaN(), 0)),
               std::invalid_argument);
  EXPECT_THROW(m.distance(Vec2(0, std::numeric_limits<double>::infinity())), std::invalid_argument);
  EXPECT_THROW(m.sampleLines(0.0), std::invalid_argument);
  EXPECT_THROW(m.sampleLines(-1.0), std::invalid_argument);
}

TEST(FieldModel, RejectsInconsistentDimensions) {
  FieldDimensions d = loadFieldPreset("fu2004").dimensions();
  d.goal_area_width = 6.0;
  EXPECT_THROW(FieldModel{d}, std::invalid_argument);
  d = loadFieldPreset("fu2004").dimensions();
  d.line_width = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(FieldModel{d}, std::invalid_argument);
  d = loadFieldPreset("fu2004").dimensions();
  d.corner_arc_radius = 0.6;  // would cross the penalty area side line 0.5 m from the touch line
  EXPECT_THROW(FieldModel{d}, std::invalid_argument);
  d = loadFieldPreset("fu2004").dimensions();
  EXPECT_NO_THROW(FieldModel{d});
}

TEST(GoalColour, Names) {
  EXPECT_EQ(goalColourName(GoalColour::kYellow), "yellow");
  EXPECT_EQ(goalColourName(GoalColour::kBlue), "blue");
  EXPECT_EQ(goalColourName(GoalColour::kWhite), "white");
}

}  // namespace field_model_test
}  // namespace fieldline::field
