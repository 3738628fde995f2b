// The block classifier against a plain reference: every pixel classified through the colour
// table, then the claims in order, then the majority (ties to the lower class number).
#include "services/region_tracking/frame_classifier.hpp"

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
