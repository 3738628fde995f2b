// Stage 4: principal directions and collinear groups in topological order.
#include "services/feature_recognition/line_structure.hpp"

#include "services/feature_recognition/junctions.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace line_structure_test {

TEST(LineStructure, FindsTheDirectionsDespiteOutliersAndGroupsCollinearPieces) {
  std::mt19937 rng(15);
  const double angle = 0.4;
  const Vec2 u(std::cos(angle), std::sin(angle)), w(-u.y(), u.x());
  // Three parallel lines (one broken in two collinear pieces), one perpendicular line and one
  // outlier at 45 degrees to both.
  std::vector<std::vector<Vec2>> runs = {
      test::polyline({-2 * u + 1.0 * w, 2 * u + 1.0 * w}, 0.1, 0.01, rng),
      test::polyline({-3 * u + 2.5 * w, -1 * u + 2.5 * w}, 0.1, 0.01, rng),
      test::polyline({0.5 * u + 2.6 * w, 3 * u + 2.6 * w}, 0.1, 0.01, rng),
      test::polyline({-1 * u - 1.0 * w, 2 * u - 1.0 * w}, 0.1, 0.01, rng),
      test::polyline({3 * u - 1 * w, 3 * u + 3 * w}, 0.1, 0.01, rng),
      test::polyline({-1.0 * (u + w), 1.0 * (u + w)}, 0.1, 0.0, rng)};
  Contours c = test::contoursOf(runs);
  Classified classified;
  classifyPieces(c, RecognitionParams{}, classified);
  ASSERT_EQ(classified.lines.size(), 6u);
  LineStructure s;
  buildLineStructure(c, classified.lines, {}, RecognitionParams{}, s);
  ASSERT_TRUE(s.found);
  // psi0 is the direction of u or of w (mod pi).
  const double d0 = std::abs(std::remainder(s.psi0 - angle, std::numbers::pi / 2));
  EXPECT_LT(d0, 0.01);
  // Lines along u are perpendicular to the axis along w.
  const int along_u = std::abs(s.axes[0].dot(w)) > 0.99 ? 0 : 1;
  const auto& groups = s.groups[along_u];
  ASSERT_EQ(groups.size(), 3u);
  const double sign = s.axes[along_u].dot(w) > 0 ? 1.0 : -1.0;
  std::vector<double> offsets;
  for (const auto& g : groups)
    offsets.push_back(sign * g.t);
  // Sorted along the axis; the broken line is one group over both pieces.
  EXPECT_LT(groups[0].t, groups[1].t);
  EXPECT_LT(groups[1].t, groups[2].t);
  std::sort(offsets.begin(), offsets.end());
  EXPECT_NEAR(offsets[0], -1.0, 0.02);
  EXPECT_NEAR(offsets[1], 1.0, 0.02);
  EXPECT_NEAR(offsets[2], 2.55, 0.06);
  for (const auto& g : groups) {
    if (g.members.size() == 2) {
      EXPECT_NEAR(g.line.length(), 6.0, 0.1);
      // The pieces are 1.5 m apart (more than group_run_gap): two runs, 2 m and 2.5 m, sorted
      // along the line and within its extent.
      ASSERT_EQ(g.runs.size(), 2u);
      EXPECT_LT(g.runs[0].t_max, g.runs[1].t_min);
      EXPECT_NEAR(g.runs[1].t_min - g.runs[0].t_max, 1.5, 0.1);
      EXPECT_NEAR(g.runs[0].length() + g.runs[1].length(), 4.5, 0.1);
      EXPECT_NEAR(g.runs[0].t_min, g.line.t_min, 1e-9);
      EXPECT_NEAR(g.runs[1].t_max, g.line.t_max, 1e-9);
      EXPECT_EQ(g.runs[0].count + g.runs[1].count, g.line.count);
    } else {
      EXPECT_EQ(g.runs.size(), 1u);
    }
  }
  // With a gap larger than the pieces' one, one run.
  RecognitionParams wide;
  wide.group_run_gap = 2.0;
  LineStructure joined;
  buildLineStructure(c, classified.lines, {}, wide, joined);
  for (const auto& g : joined.groups[along_u])
    EXPECT_EQ(g.runs.size(), 1u);
  // The outlier is in no group; the perpendicular line is the other axis's only group.
  ASSERT_EQ(s.groups[1 - along_u].size(), 1u);
  EXPECT_NEAR(std::abs(s.groups[1 - along_u][0].t), 3.0, 0.02);
}

// An L-corner whose front line has a collinear fragment 2.5 m beyond the corner (a piece of
// clutter, or another line's stub, on its extension): the fragment joins the line's group, but
// the junction is taken from the run at the corner, so it stays an L with its true leg lengths
// (before the runs, the group passed through the corner and made it a T).
TEST(LineStructure, AFragmentFarBeyondACornerLeavesItAnL) {
  std::mt19937 rng(3);
  const std::vector<std::vector<Vec2>> runs = {
      test::polyline({{1.0, 2.0}, {1.0, 0.5}}, 0.1, 0.005, rng),     // front line, ends at (1, 0.5)
      test::polyline({{1.0, 0.5}, {3.0, 0.5}}, 0.1, 0.005, rng),     // side line, from the corner
      test::polyline({{1.0, 2.0}, {-2.0, 2.0}}, 0.1, 0.005, rng),    // a third line (the structure)
      test::polyline({{1.0, -2.0}, {1.0, -2.4}}, 0.1, 0.005, rng)};  // fragment on the extension
  Contours c = test::contoursOf(runs);
  Classified classified;
  classifyPieces(c, RecognitionParams{}, classified);
  ASSERT_EQ(classified.lines.size(), 4u);
  auto cornerAt = [&](const RecognitionParams& params, Junction& found) {
    LineStructure s;
    buildLineStructure(c, classified.lines, {}, params, s);
    std::vector<Junction> junctions;
    findJunctions(s, params, junctions);
    for (const Junction& j : junctions) {
      if ((j.position - Vec2(1.0, 0.5)).norm() < 0.1) {
        found = j;
        return true;
      }
    }
    return false;
  };
  Junction j;
  ASSERT_TRUE(cornerAt(RecognitionParams{}, j));
  EXPECT_FALSE(j.is_t);
  ASSERT_EQ(j.leg_count, 2);
  for (int k = 0; k < 2; ++k) {
    if (std::abs(j.legs[k].y()) > 0.9) {
      EXPECT_GT(j.legs[k].y(), 0.0);  // the front line leaves the corner toward +y
      EXPECT_NEAR(j.leg_lengths[k], 1.5, 0.05);
    } else {
      EXPECT_NEAR(j.leg_lengths[k], 2.0, 0.05);
    }
  }
  // Runs chained over the gap: the front line passes through the corner, a T.
  RecognitionParams joined;
  joined.group_run_gap = 5.0;
  ASSERT_TRUE(cornerAt(joined, j));
  EXPECT_TRUE(j.is_t);
}

TEST(LineStructure, ExcludedPiecesAndNoLines) {
  LineStructure s;
  buildLineStructure(Contours{}, {}, {}, RecognitionParams{}, s);
  EXPECT_FALSE(s.found);
  double psi0 = 0.0;
  EXPECT_FALSE(principalDirection({}, 0.3, psi0));
}

}  // namespace line_structure_test
}  // namespace fieldline::feature_recognition
