// Boundary extraction on the connectivity grid: closed contours that separate exactly the
// region's cells from the rest.
#include "services/region_tracking/contours.hpp"

#include <cstdlib>
#include <random>
#include <stdexcept>
#include <utility>

#include <gtest/gtest.h>

#include "services/region_tracking/region_tracker.hpp"
#include "tests/unit/region_tracking/synthetic_grid.hpp"

namespace fieldline::region_tracking {
namespace contours_test {

using testing::ClassGrid;
using testing::labelComponents;

// Adds every boundary side of the cells of class c and extracts the contours.
ContourSet contoursOf(const ClassGrid& g, ClassId c, int cell_size = 1,
                      PaddedLayout::Pitch pitch = PaddedLayout::kCompactPitch) {
  const CellGrid grid{g.width, g.height, cell_size};
  ConnectivityGrid connectivity(grid, PaddedLayout(grid, pitch));
  std::vector<Cell> boundary;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      if (g.at(x, y) != c) continue;
      bool any = false;
      for (int side = 0; side < 4; ++side) {
        const int nx = x + kSideDx[side], ny = y + kSideDy[side];
        if (!g.contains(nx, ny) || g.at(nx, ny) != c) {
          connectivity.addBoundarySide(x, y, side);
          any = true;
        }
      }
      if (any) boundary.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
    }
  }
  ContourSet out;
  connectivity.extractContours(boundary, c, out);
  EXPECT_TRUE(connectivity.isClear());
  return out;
}

// Every step between consecutive points (and from the last back to the first) is one cell side.
void expectClosed(const ContourSet& set, int cell_size) {
  for (const Contour& contour : set.contours) {
    const auto points = set.pointsOf(contour);
    ASSERT_GE(points.size(), 4u);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const ContourPoint& p = points[i];
      const ContourPoint& q = points[(i + 1) % points.size()];
      EXPECT_EQ(std::abs(p.x - q.x) + std::abs(p.y - q.y), cell_size);
    }
  }
}

// Winding number of each cell centre from the vertical edges to its right: 1 inside a region,
// 0 outside and in holes. This is what "the contours separate the region from the rest" means.
std::vector<int> windingOf(const ContourSet& set, int width, int height, int cell_size) {
  std::vector<int> winding(width * height, 0);
  for (const Contour& contour : set.contours) {
    const auto points = set.pointsOf(contour);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const ContourPoint& p = points[i];
      const ContourPoint& q = points[(i + 1) % points.size()];
      if (p.x != q.x) continue;
      const int x = p.x / cell_size;
      const int row = std::min(p.y, q.y) / cell_size;
      const int sign = q.y > p.y ? 1 : -1;  // downward edges are right sides of a region
      for (int cx = 0; cx < x && cx < width; ++cx)
        winding[row * width + cx] += sign;
    }
  }
  return winding;
}

TEST(Contours, SingleCellIsAClockwiseSquare) {
  ClassGrid g(3, 3, 0);
  g.at(1, 1) = 1;
  const ContourSet set = contoursOf(g, 1, 4);
  ASSERT_EQ(set.contours.size(), 1u);
  const Contour& c = set.contours[0];
  EXPECT_TRUE(c.outer);
  EXPECT_EQ(c.signed_cell_area, 1);
  const std::vector<ContourPoint> expected = {{4, 4}, {8, 4}, {8, 8}, {4, 8}};
  const auto points = set.pointsOf(c);
  EXPECT_EQ(std::vector<ContourPoint>(points.begin(), points.end()), expected);
}

TEST(Contours, RegionWithHoleHasOuterAndInnerContour) {
  ClassGrid g(10, 10, 0);
  g.fillRect(1, 1, 9, 9, 1);
  g.fillRect(4, 4, 6, 6, 0);
  const ContourSet set = contoursOf(g, 1);
  ASSERT_EQ(set.contours.size(), 2u);
  int outerArea = 0, holeArea = 0;
  for (const Contour& c : set.contours)
    (c.outer ? outerArea : holeArea) = c.signed_cell_area;
  EXPECT_EQ(outerArea, 64);
  EXPECT_EQ(holeArea, -4);
  EXPECT_EQ(set.points.size(), 32u + 8u);
}

TEST(Contours, CellsTouchingAtACornerGetSeparateContours) {
  // Not 4-connected, so two regions: the turning rule must not join them at the shared corner.
  ClassGrid g(4, 4, 0);
  g.at(1, 1) = 1;
  g.at(2, 2) = 1;
  const ContourSet set = contoursOf(g, 1);
  EXPECT_EQ(set.contours.size(), 2u);
  for (const Contour& c : set.contours)
    EXPECT_EQ(c.size(), 4);
  // And a ring closed only through corners has no hole of its own: each cell is one region.
  ClassGrid ring(5, 5, 0);
  ring.at(2, 1) = ring.at(1, 2) = ring.at(3, 2) = ring.at(2, 3) = 1;
  EXPECT_EQ(contoursOf(ring, 1).contours.size(), 4u);
}

TEST(Contours, RandomShapesGiveClosedContoursThatSeparateExactlyTheRegion) {
  std::mt19937 rng(99);
  std::bernoulli_distribution coin(0.45);
  for (int trial = 0; trial < 100; ++trial) {
    // Noise is the hardest case: many corner contacts, holes inside holes.
    ClassGrid g = trial % 2 ? testing::randomBlobs(40, 30, rng) : ClassGrid(40, 30, 0);
    if (trial % 2 == 0) {
      for (auto& cell : g.cells)
        cell = coin(rng) ? 1 : 0;
    }
    const int cell_size = trial % 4 == 0 ? 4 : 1;
    const ContourSet set = contoursOf(g, 1, cell_size);
    expectClosed(set, cell_size);
    const std::vector<int> winding = windingOf(set, g.width, g.height, cell_size);
    for (int i = 0; i < g.width * g.height; ++i) {
      ASSERT_EQ(winding[i], g.cells[i] == 1 ? 1 : 0) << "trial " << trial << " cell " << i;
    }
    std::vector<int> labels;
    const int regions = labelComponents(
        g.width, g.height, [&](int i) { return g.cells[i] == 1; }, labels);
    int outer = 0;
    for (const Contour& c : set.contours)
      outer += c.outer ? 1 : 0;
    EXPECT_EQ(outer, regions) << "trial " << trial;
  }
}

TEST(Contours, APowerOfTwoPitchMapsEveryCellAndGivesTheSameContours) {
  // 30 + 2 is a power of two already; 31 + 2 and 62 + 2 + ... are not.
  for (const auto& [width, height] : {std::pair{30, 7}, {31, 9}, {63, 20}, {80, 60}, {1, 1}}) {
    const CellGrid grid{width, height, 4};
    const PaddedLayout compact(grid);
    const PaddedLayout pow2(grid, PaddedLayout::kPowerOfTwoPitch);
    EXPECT_EQ(compact.width, width + 2);
    EXPECT_EQ(compact.pitch_shift, -1);
    EXPECT_GE(pow2.width, width + 2);
    EXPECT_LT(pow2.width, 2 * (width + 2));
    EXPECT_EQ(pow2.width, 1 << pow2.pitch_shift);
    EXPECT_EQ(pow2.height, height + 2);
    for (int y = -1; y <= height; ++y) {
      for (int x = -1; x <= width; ++x) {
        const int i = pow2.index(x, y);
        ASSERT_EQ(pow2.x(i), x);
        ASSERT_EQ(pow2.y(i), y);
        ASSERT_EQ((i & (pow2.width - 1)) - 1, x);
        ASSERT_EQ((i >> pow2.pitch_shift) - 1, y);
        ASSERT_LT(i, pow2.size());
      }
    }
  }
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const ClassGrid g = testing::randomBlobs(37 + trial, 23, rng);
    const ContourSet compact = contoursOf(g, 1, 4);
    const ContourSet pow2 = contoursOf(g, 1, 4, PaddedLayout::kPowerOfTwoPitch);
    ASSERT_FALSE(compact.contours.empty());
    EXPECT_EQ(compact.points, pow2.points) << "trial " << trial;
    ASSERT_EQ(compact.contours.size(), pow2.contours.size());
    for (std::size_t i = 0; i < compact.contours.size(); ++i) {
      EXPECT_EQ(compact.contours[i].begin, pow2.contours[i].begin);
      EXPECT_EQ(compact.contours[i].end, pow2.contours[i].end);
      EXPECT_EQ(compact.contours[i].signed_cell_area, pow2.contours[i].signed_cell_area);
    }
  }
  const CellGrid grid{10, 10, 4};
  EXPECT_THROW(ConnectivityGrid(grid, PaddedLayout(CellGrid{8, 10, 4})), std::invalid_argument);
}

TEST(Contours, TrackerBoundariesSeparateItsRegionsAndLeaveTheGridClear) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 30; ++trial) {
    const ClassGrid g = testing::randomBlobs(50, 40, rng);
    TrackerConfig config;
    config.cell_size = 1;
    config.classes = {{1, true, 1000, 1, kNoClass}, {2, true, 1000, 1, kNoClass}};
    RegionTracker tracker(CellGrid{50, 40, 1}, config);
    tracker.track(ClassMapClassifier(g.cells, g.width));
    const ContourSet& set = tracker.contours();
    expectClosed(set, 1);
    for (const ClassId c : {ClassId{1}, ClassId{2}}) {
      ContourSet ofClass;
      for (const Contour& contour : set.contours) {
        if (contour.class_id != c) continue;
        Contour copy = contour;
        copy.begin = static_cast<int>(ofClass.points.size());
        for (const ContourPoint& p : set.pointsOf(contour))
          ofClass.points.push_back(p);
        copy.end = static_cast<int>(ofClass.points.size());
        ofClass.contours.push_back(copy);
      }
      const std::vector<int> winding = windingOf(ofClass, 50, 40, 1);
      for (int i = 0; i < 50 * 40; ++i) {
        ASSERT_EQ(winding[i], g.cells[i] == c ? 1 : 0) << "trial " << trial;
      }
    }
  }
}

}  // namespace contours_test
}  // namespace fieldline::region_tracking
