// The full-frame baselines agree with a plain labelling, and the tracker agrees with baseline
// (a) once converged.
#include "services/region_tracking/baselines.hpp"

#include <algorithm>
#include <map>
#include <random>
#include <tuple>

#include <gtest/gtest.h>

#include "services/region_tracking/region_tracker.hpp"
#include "tests/unit/region_tracking/synthetic_grid.hpp"

namespace fieldline::region_tracking {
namespace baselines_test {

using testing::ClassGrid;
using testing::labelComponents;

const std::vector<ClassId> kClasses = {1, 2};

// A contour as the sorted list of its directed edges: independent of where following started.
using EdgeList = std::vector<std::tuple<int, int, int, int>>;
std::multiset<std::tuple<int, bool, EdgeList>> canonical(const ContourSet& set) {
  std::multiset<std::tuple<int, bool, EdgeList>> out;
  for (const Contour& c : set.contours) {
    const auto points = set.pointsOf(c);
    EdgeList edges;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const ContourPoint& q = points[(i + 1) % points.size()];
      edges.emplace_back(points[i].x, points[i].y, q.x, q.y);
    }
    std::sort(edges.begin(), edges.end());
    out.emplace(c.class_id, c.outer, std::move(edges));
  }
  return out;
}

// Region sizes per class, sorted: what both baselines and a plain labelling must agree on.
std::map<ClassId, std::vector<int>> sizesByClass(std::span<const Region> regions) {
  std::map<ClassId, std::vector<int>> out;
  for (const Region& r : regions)
    out[r.class_id].push_back(r.cells);
  for (auto& [c, sizes] : out)
    std::sort(sizes.begin(), sizes.end());
  return out;
}

TEST(Baselines, RegionsMatchAPlainLabellingAndEachOther) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 40; ++trial) {
    const ClassGrid g = testing::randomBlobs(64, 48, rng);
    const CellGrid grid{64, 48, 4};
    CmvisionSegmenter cmvision(grid, kClasses);
    OpenCvSegmenter opencv(grid, kClasses);
    const ClassMapClassifier classifier(g.cells, g.width);
    cmvision.segment(classifier);
    opencv.segment(classifier);

    std::map<ClassId, std::vector<int>> expected;
    for (const ClassId c : kClasses) {
      std::vector<int> labels;
      const int n = labelComponents(
          64, 48, [&](int i) { return g.cells[i] == c; }, labels);
      std::vector<int> sizes(n, 0);
      for (const int l : labels) {
        if (l >= 0) ++sizes[l];
      }
      std::sort(sizes.begin(), sizes.end());
      if (n > 0) expected[c] = sizes;
    }
    EXPECT_EQ(sizesByClass(cmvision.regions()), expected) << "trial " << trial;
    EXPECT_EQ(sizesByClass(opencv.regions()), expected) << "trial " << trial;

    // Bounding boxes hold every cell of their region.
    std::vector<int> labels;
    cmvision.labelCells(labels);
    for (int i = 0; i < 64 * 48; ++i) {
      if (labels[i] < 0) continue;
      const Region& r = cmvision.regions()[labels[i]];
      EXPECT_EQ(r.class_id, g.cells[i]);
      EXPECT_TRUE(r.min_x <= i % 64 && i % 64 <= r.max_x && r.min_y <= i / 64 && i / 64 <= r.max_y);
    }
    // OpenCV's contours: one outer per 8-connected blob at least, points on cell centres.
    EXPECT_FALSE(opencv.contours().contours.empty());
    for (const ContourPoint& p : opencv.contours().points) {
      EXPECT_EQ(p.x % 4, 2);
      EXPECT_EQ(p.y % 4, 2);
    }
  }
}

// Counts the cells a full-frame pass reads.
class CountingClassifier final : public CellClassifier {
 public:
  explicit CountingClassifier(const ClassGrid& g) : grid_(g) {}
  ClassId classify(int x, int y) const override {
    ++reads;
    return grid_.at(x, y);
  }
  mutable int reads = 0;

 private:
  const ClassGrid& grid_;
};

TEST(Baselines, DontTouchCellsAreLeftOutOfTheRegionsAndReadOnlyWhenAsked) {
  ClassGrid g(20, 10, 1);
  std::vector<std::uint8_t> dontTouch(200, 0);
  for (int y = 0; y < 10; ++y)
    dontTouch[y * 20 + 10] = 1;
  for (const FullFramePolicy policy :
       {FullFramePolicy::kClassifyEveryCell, FullFramePolicy::kSkipDontTouch}) {
    CmvisionSegmenter cmvision(CellGrid{20, 10, 1}, kClasses, dontTouch, policy);
    CountingClassifier classifier(g);
    cmvision.segment(classifier);
    EXPECT_EQ(cmvision.regions().size(), 2u);
    EXPECT_EQ(cmvision.classMap()[10], kNoClass);
    EXPECT_EQ(classifier.reads, policy == FullFramePolicy::kSkipDontTouch ? 190 : 200);
    OpenCvSegmenter opencv(CellGrid{20, 10, 1}, kClasses, dontTouch, policy);
    opencv.segment(classifier);
    EXPECT_EQ(opencv.regions().size(), 2u);
  }
}

TEST(Baselines, ConvergedTrackerEqualsCmvisionRegionsAndContours) {
  std::mt19937 rng(23);
  std::uniform_int_distribution<int> shift(-2, 2);
  for (int trial = 0; trial < 30; ++trial) {
    ClassGrid g = testing::randomBlobs(64, 48, rng);
    const CellGrid grid{64, 48, 4};
    TrackerConfig config;
    config.cell_size = 4;
    config.classes = {{1, true, 1000, 1, kNoClass}, {2, true, 1000, 1, kNoClass}};
    RegionTracker tracker(grid, config);
    CmvisionSegmenter cmvision(grid, kClasses);
    for (int frame = 0; frame < 4; ++frame) {
      const ClassMapClassifier classifier(g.cells, g.width);
      tracker.track(classifier);
      cmvision.segment(classifier);
      const Agreement agreement = compareWithFullSegmentation(tracker.visited(), cmvision);
      EXPECT_TRUE(agreement.exact()) << "trial " << trial << " frame " << frame;
      if (frame == 0) {
        // Everything seeded: identical regions, identical contours.
        EXPECT_EQ(agreement.regions_untracked, 0);
        EXPECT_EQ(canonical(tracker.contours()), canonical(cmvision.contours()));
      }
      if (agreement.regions_untracked == 0) {
        EXPECT_EQ(canonical(tracker.contours()), canonical(cmvision.contours()));
      }
      g = g.shifted(shift(rng), shift(rng), 0);
    }
  }
}

// The boundaries as the plain rule defines them: every side of a tracked cell whose neighbour
// (or the grid's edge) has another class, cells listed per class in scan order, contours
// followed in that order. Baseline (a) marks them from its runs instead; the output must be
// the same, contour for contour and point for point.
ContourSet contoursCellByCell(const CellGrid& grid, std::span<const ClassId> classMap,
                              std::span<const ClassId> tracked) {
  ConnectivityGrid connectivity(grid);
  ContourSet out;
  for (const ClassId c : tracked) {
    std::vector<Cell> boundaryCells;
    for (int y = 0; y < grid.height; ++y) {
      for (int x = 0; x < grid.width; ++x) {
        if (classMap[grid.index(x, y)] != c) continue;
        bool atBoundary = false;
        for (int side = 0; side < 4; ++side) {
          const int nx = x + kSideDx[side], ny = y + kSideDy[side];
          if (!grid.contains(nx, ny) || classMap[grid.index(nx, ny)] != c) {
            connectivity.addBoundarySide(x, y, side);
            atBoundary = true;
          }
        }
        if (atBoundary)
          boundaryCells.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
      }
    }
    connectivity.extractContours(boundaryCells, c, out);
  }
  return out;
}

void expectIdentical(const ContourSet& actual, const ContourSet& expected, int trial) {
  ASSERT_EQ(actual.contours.size(), expected.contours.size()) << "trial " << trial;
  EXPECT_EQ(actual.points, expected.points) << "trial " << trial;
  for (std::size_t i = 0; i < expected.contours.size(); ++i) {
    const Contour& a = actual.contours[i];
    const Contour& e = expected.contours[i];
    EXPECT_EQ(std::tie(a.class_id, a.outer, a.signed_cell_area, a.begin, a.end),
              std::tie(e.class_id, e.outer, e.signed_cell_area, e.begin, e.end))
        << "trial " << trial << " contour " << i;
  }
}

TEST(Baselines, CmvisionBoundariesFromRunsEqualTheCellByCellRule) {
  std::mt19937 rng(29);
  std::bernoulli_distribution noisy(0.3);
  std::uniform_int_distribution<int> anyClass(0, 3);
  const std::vector<ClassId> tracked = {2, 1, 3};  // not in id order; class 0 untracked
  for (int trial = 0; trial < 60; ++trial) {
    const int width = 40 + trial % 7, height = 30 + trial % 5;
    ClassGrid g = testing::randomBlobs(width, height, rng);
    // Salt of single cells (all four classes) in some grids: runs of length one, corners.
    if (noisy(rng)) {
      for (ClassId& c : g.cells) {
        if (noisy(rng)) c = static_cast<ClassId>(anyClass(rng));
      }
    }
    const CellGrid grid{width, height, 4};
    // A disc-shaped view in every other grid, as the mirror's.
    std::vector<std::uint8_t> dontTouch;
    if (trial % 2 == 1) {
      dontTouch.assign(grid.cellCount(), 0);
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
          const double dx = x - width / 2.0, dy = y - height / 2.0;
          dontTouch[grid.index(x, y)] = dx * dx + dy * dy > 0.2 * width * width ? 1 : 0;
        }
      }
    }
    CmvisionSegmenter cmvision(grid, tracked, dontTouch);
    cmvision.segment(ClassMapClassifier(g.cells, g.width));
    const ContourSet expected = contoursCellByCell(grid, cmvision.classMap(), tracked);
    ASSERT_FALSE(expected.contours.empty());
    expectIdentical(cmvision.contours(), expected, trial);
    // Segmenting again (reused buffers) gives the same.
    cmvision.segment(ClassMapClassifier(g.cells, g.width));
    expectIdentical(cmvision.contours(), expected, trial);
  }
}

// Regions and contours of (b) as a list, in output order.
using OpenCvOutput =
    std::tuple<std::vector<std::tuple<int, int, int, int, int, int>>,
               std::vector<std::tuple<int, bool, int, int, int>>, std::vector<std::pair<int, int>>>;
OpenCvOutput outputOf(const OpenCvSegmenter& s) {
  OpenCvOutput out;
  for (const Region& r : s.regions())
    std::get<0>(out).emplace_back(r.class_id, r.cells, r.min_x, r.min_y, r.max_x, r.max_y);
  for (const Contour& c : s.contours().contours)
    std::get<1>(out).emplace_back(c.class_id, c.outer, c.signed_cell_area, c.begin, c.end);
  for (const ContourPoint& p : s.contours().points)
    std::get<2>(out).emplace_back(p.x, p.y);
  return out;
}

TEST(Baselines, OpenCvSkippingAbsentClassesGivesTheSameOutput) {
  std::mt19937 rng(31);
  // Classes 3 and 4 never occur in randomBlobs; class 2 is removed from some grids.
  const std::vector<ClassId> tracked = {3, 1, 4, 2};
  for (int trial = 0; trial < 30; ++trial) {
    ClassGrid g = testing::randomBlobs(48, 36, rng);
    if (trial % 3 == 0) std::replace(g.cells.begin(), g.cells.end(), ClassId{2}, ClassId{0});
    g.fillRect(0, 0, 3, 3, 1);  // class 1 is always present
    const CellGrid grid{48, 36, 4};
    OpenCvSegmenter skipping(grid, tracked, {}, FullFramePolicy::kClassifyEveryCell,
                             AbsentClasses::kSkip);
    OpenCvSegmenter labelling(grid, tracked, {}, FullFramePolicy::kClassifyEveryCell,
                              AbsentClasses::kLabel);
    const ClassMapClassifier classifier(g.cells, g.width);
    skipping.segment(classifier);
    labelling.segment(classifier);
    EXPECT_FALSE(skipping.regions().empty());
    EXPECT_EQ(outputOf(skipping), outputOf(labelling)) << "trial " << trial;
  }
}

TEST(Baselines, AgreementCountsAJumpedIslandAsStaleCells) {
  ClassGrid a(30, 20, 1);
  const CellGrid grid{30, 20, 1};
  TrackerConfig config;
  config.cell_size = 1;
  config.classes = {{1, true, 10, 1, kNoClass}};
  RegionTracker tracker(grid, config);
  CmvisionSegmenter cmvision(grid, {kClasses.data(), 1});
  tracker.track(ClassMapClassifier(a.cells, a.width));
  ClassGrid b = a;
  b.fillRect(10, 8, 13, 11, 0);  // appears inside, away from any drop
  tracker.track(ClassMapClassifier(b.cells, b.width));
  cmvision.segment(ClassMapClassifier(b.cells, b.width));
  const Agreement agreement = compareWithFullSegmentation(tracker.visited(), cmvision);
  EXPECT_EQ(agreement.stale_cells, 9);
  EXPECT_EQ(agreement.regions_tracked, 1);
  EXPECT_FALSE(agreement.exact());
}

}  // namespace baselines_test
}  // namespace fieldline::region_tracking
