// The block classifier against a plain reference: every pixel classified through the colour
// table, then the claims in order, then the majority (ties to the lower class number).
#include "services/region_tracking/frame_classifier.hpp"

#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace fieldline::region_tracking {
namespace frame_classifier_test {

using camera::ColourClass;

camera::ColourTable testTable() {
  // Four boxes covering parts of the YUV cube; the rest is unknown.
  return camera::ColourTable({
      {ColourClass::kGreen, {40, 200}, {0, 110}, {0, 110}},
      {ColourClass::kWhite, {201, 255}, {100, 156}, {100, 156}},
      {ColourClass::kOrange, {60, 220}, {0, 120}, {160, 255}},
      {ColourClass::kBlack, {0, 39}, {0, 255}, {0, 255}},
  });
}

// A frame whose pixels are drawn from a few prototype colours, in patches so that uniform and
// mixed cells both occur.
std::vector<std::uint8_t> randomFrame(int width, int height, camera::PixelFormat format,
                                      std::mt19937& rng) {
  const std::uint8_t prototypes[5][3] = {
      {120, 60, 60}, {230, 128, 128}, {150, 80, 200}, {20, 128, 128}, {120, 200, 40}};
  std::uniform_int_distribution<int> pick(0, 4);
  std::uniform_int_distribution<int> noise(-3, 3);
  std::bernoulli_distribution change(0.15);
  const int bytesPerPixel = format == camera::PixelFormat::kYuyv ? 2 : 3;
  std::vector<std::uint8_t> data(static_cast<std::size_t>(width) * height * bytesPerPixel);
  int current = pick(rng);
  auto jitter = [&](int value) {
    return static_cast<std::uint8_t>(std::clamp(value + noise(rng), 0, 255));
  };
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; u += 2) {
      if (change(rng)) current = pick(rng);
      const int second = change(rng) ? pick(rng) : current;
      std::uint8_t* p = data.data() + (static_cast<std::size_t>(v) * width + u) * bytesPerPixel;
      if (format == camera::PixelFormat::kYuyv) {
        // Y0 U Y1 V: the pair shares U and V.
        p[0] = jitter(prototypes[current][0]);
        p[1] = jitter(prototypes[current][1]);
        p[2] = jitter(prototypes[second][0]);
        p[3] = jitter(prototypes[current][2]);
      } else {
        for (int k = 0; k < 3; ++k) {
          p[k] = jitter(prototypes[current][k]);
          p[3 + k] = jitter(prototypes[second][k]);
        }
      }
    }
  }
  return data;
}

ClassId referenceClass(const camera::ColourTable& table, const camera::FrameView& frame, int x,
                       int y, int size, const BlockClassifierParams& params) {
  std::array<int, camera::kColourClassCount> votes{};
  for (int v = y * size; v < (y + 1) * size; ++v) {
    for (int u = x * size; u < (x + 1) * size; ++u)
      ++votes[static_cast<std::size_t>(table.classifyPixel(frame, u, v))];
  }
  for (const BlockClaim& claim : params.claims) {
    const int pixels = std::max(1, static_cast<int>(std::ceil(claim.min_fraction * size * size)));
    if (votes[static_cast<std::size_t>(claim.colour)] >= pixels) return classIdOf(claim.colour);
  }
  int best = 0;
  for (int c = 1; c < camera::kColourClassCount; ++c) {
    if (votes[c] > votes[best]) best = c;
  }
  return static_cast<ClassId>(best);
}

TEST(FrameCellClassifier, EqualsPixelByPixelVotingForEveryCellSizeAndFormat) {
  const camera::ColourTable table = testTable();
  const BlockClassifierParams params;  // orange, then white claim at 1/8
  std::mt19937 rng(7);
  int mixedCells = 0, uniformCells = 0;
  for (const camera::PixelFormat format : {camera::PixelFormat::kYuyv, camera::PixelFormat::kBgr}) {
    for (const int size : {1, 2, 4, 8}) {
      const int width = 64, height = 48;
      const std::vector<std::uint8_t> data = randomFrame(width, height, format, rng);
      camera::FrameView frame{data.data(), width, height,
                              camera::FrameView::minStride(width, format), format};
      FrameCellClassifier classifier(table, size, params);
      classifier.setFrame(frame);
      const CellGrid grid = CellGrid::forImage(width, height, size);
      for (int y = 0; y < grid.height; ++y) {
        std::vector<ClassId> row(grid.width - 1);
        classifier.classifyRow(y, 1, row);
        for (int x = 0; x < grid.width; ++x) {
          const ClassId expected = referenceClass(table, frame, x, y, size, params);
          ASSERT_EQ(classifier.classify(x, y), expected)
              << "size " << size << " cell " << x << "," << y;
          if (x > 0) {
            ASSERT_EQ(row[x - 1], expected);
          }
          const ClassId first = classIdOf(table.classifyPixel(frame, x * size, y * size));
          (expected == first ? uniformCells : mixedCells) += 1;
        }
      }
    }
  }
  // Both paths (a single class, and the vote) were exercised.
  EXPECT_GT(mixedCells, 100);
  EXPECT_GT(uniformCells, 100);
}

TEST(FrameCellClassifier, RejectsUnsupportedCellSizes) {
  const camera::ColourTable table = testTable();
  EXPECT_THROW(FrameCellClassifier(table, 3), std::invalid_argument);
  EXPECT_THROW(FrameCellClassifier(table, 16), std::invalid_argument);
}

}  // namespace frame_classifier_test
}  // namespace fieldline::region_tracking

namespace fieldline::region_tracking {
namespace class_lookup_test {

using camera::ColourClass;

// Every (Y, U, V) of the 2^24, against the table it was made from.
int cellsDiffering(const ClassLookup& lookup, const camera::ColourTable& table) {
  int differing = 0;
  for (int y = 0; y < 256; ++y) {
    for (int u = 0; u < 256; ++u) {
      for (int v = 0; v < 256; ++v) {
        const auto cy = static_cast<std::uint8_t>(y), cu = static_cast<std::uint8_t>(u),
                   cv = static_cast<std::uint8_t>(v);
        differing += lookup.classifyYuv(cy, cu, cv) != table.classifyYuv(cy, cu, cv) ? 1 : 0;
      }
    }
  }
  return differing;
}

// A table with a different class in nearly every 4x4x4 block, so that a wrong block or place in
// the lookup shows.
camera::ColourTable checkerTable() {
  std::vector<ColourClass> cells(camera::ColourTable::kCells);
  for (std::size_t i = 0; i < cells.size(); ++i)
    cells[i] = static_cast<ColourClass>((i * 7 + i / 64 + i / 4096) % 6);
  return camera::ColourTable::fromLookup(std::move(cells));
}

TEST(ClassLookup, GivesTheTablesClassForEveryYuvAndFollowsARebuild) {
  const camera::ColourTable boxes = frame_classifier_test::testTable();
  const camera::ColourTable checker = checkerTable();
  ClassLookup lookup(boxes);
  EXPECT_EQ(cellsDiffering(lookup, boxes), 0);
  EXPECT_GT(cellsDiffering(lookup, checker), 1000000);
  lookup.rebuild(checker);
  EXPECT_EQ(cellsDiffering(lookup, checker), 0);
  // A copy reads its own cells, at a cache line's start.
  const ClassLookup copy = lookup;
  EXPECT_EQ(cellsDiffering(copy, checker), 0);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(copy.data()) % 64, 0u);
}

}  // namespace class_lookup_test
}  // namespace fieldline::region_tracking
