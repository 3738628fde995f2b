#include "common/camera/colour.hpp"

#include <random>

#include <gtest/gtest.h>

#include "common/camera/frame.hpp"
#include "common/config/config.hpp"

namespace fieldline::camera {
namespace colour_test {

TEST(Colour, NamesRoundTrip) {
  for (int c = 0; c < kColourClassCount; ++c) {
    const auto colour = static_cast<ColourClass>(c);
    EXPECT_EQ(colourFromName(colourName(colour)), colour);
  }
  EXPECT_FALSE(colourFromName("purple").has_value());
}

TEST(Colour, YuvConversionByHandAndRoundTrip) {
  const Yuv white = yuvFromBgr({255, 255, 255});
  EXPECT_EQ(white.y, 255);
  EXPECT_EQ(white.u, 128);
  EXPECT_EQ(white.v, 128);
  // Pure red: Y = 0.299 * 255 = 76.2, U = 128 + 0.564 (0 - 76.2) = 85.0,
  // V = 128 + 0.713 (255 - 76.2) = 255.5 -> 255.
  const Yuv red = yuvFromBgr({0, 0, 255});
  EXPECT_EQ(red.y, 76);
  EXPECT_EQ(red.u, 85);
  EXPECT_EQ(red.v, 255);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> c(20, 235);
  for (int k = 0; k < 2000; ++k) {
    const Bgr in{static_cast<std::uint8_t>(c(rng)), static_cast<std::uint8_t>(c(rng)),
                 static_cast<std::uint8_t>(c(rng))};
    const Bgr out = bgrFromYuv(yuvFromBgr(in));
    EXPECT_NEAR(out.b, in.b, 2);
    EXPECT_NEAR(out.g, in.g, 2);
    EXPECT_NEAR(out.r, in.r, 2);
  }
}

TEST(ColourTable, LookupAgreesWithTheBoxesAtCellCentresAndIsFirstMatch) {
  std::vector<YuvBox> boxes = {{ColourClass::kOrange, {40, 255}, {0, 110}, {170, 255}},
                               {ColourClass::kWhite, {180, 255}, {100, 156}, {100, 156}},
                               {ColourClass::kGreen, {40, 200}, {60, 120}, {40, 118}},
                               {ColourClass::kBlack, {0, 60}, {0, 255}, {0, 255}},
                               // Overlaps the green box: the green box comes first and wins.
                               {ColourClass::kBlue, {0, 255}, {90, 255}, {0, 255}}};
  const ColourTable table(boxes);
  EXPECT_EQ(table.classifyYuv(100, 90, 80), ColourClass::kGreen);
  EXPECT_EQ(table.classifyYuv(100, 200, 80), ColourClass::kBlue);
  EXPECT_EQ(table.classifyYuv(230, 128, 128), ColourClass::kWhite);
  EXPECT_EQ(table.classifyYuv(130, 60, 200), ColourClass::kOrange);
  EXPECT_EQ(table.classifyYuv(120, 40, 40), ColourClass::kUnknown);
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> cell(0, 63);
  for (int k = 0; k < 5000; ++k) {
    const Yuv c{static_cast<std::uint8_t>(cell(rng) * 4 + 2),
                static_cast<std::uint8_t>(cell(rng) * 4 + 2),
                static_cast<std::uint8_t>(cell(rng) * 4 + 2)};
    EXPECT_EQ(table.classifyYuv(c), table.classifyExact(c));
  }
}

TEST(ColourTable, BgrAndYuyvFramesOfTheSameSceneClassifyAlike) {
  const ColourTable table = loadColourTablePreset("colours_sim");
  // A 4x2 scene: carpet green, line white, ball orange, robot black (BGR).
  const Bgr scene[2][4] = {{{45, 120, 40}, {225, 230, 230}, {10, 100, 240}, {28, 28, 28}},
                           {{45, 120, 40}, {45, 120, 40}, {225, 230, 230}, {225, 230, 230}}};
  const ColourClass expected[2][4] = {
      {ColourClass::kGreen, ColourClass::kWhite, ColourClass::kOrange, ColourClass::kBlack},
      {ColourClass::kGreen, ColourClass::kGreen, ColourClass::kWhite, ColourClass::kWhite}};
  // BGR with a padded stride.
  std::vector<std::uint8_t> bgr(2 * 16, 0);
  // YUYV: pixel pairs with equal chroma, so pair (green, white) shares chroma: build pairs from
  // equal colours only and compare those.
  std::vector<std::uint8_t> yuyv(2 * 8, 0);
  for (int v = 0; v < 2; ++v) {
    for (int u = 0; u < 4; ++u) {
      const Bgr c = scene[v][u];
      bgr[v * 16 + u * 3 + 0] = c.b;
      bgr[v * 16 + u * 3 + 1] = c.g;
      bgr[v * 16 + u * 3 + 2] = c.r;
      const Yuv y = yuvFromBgr(c);
      yuyv[v * 8 + u * 2] = y.y;
      yuyv[v * 8 + (u / 2) * 4 + 1] = y.u;
      yuyv[v * 8 + (u / 2) * 4 + 3] = y.v;
    }
  }
  const FrameView bgr_view{bgr.data(), 4, 2, 16, PixelFormat::kBgr};
  const FrameView yuyv_view{yuyv.data(), 4, 2, 8, PixelFormat::kYuyv};
  ASSERT_TRUE(bgr_view.valid());
  ASSERT_TRUE(yuyv_view.valid());
  for (int v = 0; v < 2; ++v) {
    for (int u = 0; u < 4; ++u) {
      EXPECT_EQ(table.classifyPixel(bgr_view, u, v), expected[v][u]) << u << "," << v;
    }
  }
  // Row 1 has equal-colour pairs, so its YUYV chroma is exact.
  for (int u = 0; u < 4; ++u)
    EXPECT_EQ(table.classifyPixel(yuyv_view, u, 1), expected[1][u]);
  // Y is per pixel: pixel 1 of row 0 reads its own luma.
  EXPECT_EQ(readYuv(yuyv_view, 1, 0).y, yuvFromBgr(scene[0][1]).y);
  // Block majority: row 1 is half green, half white; a 2x2 block at (0, 0) holds 2 green
  // (row 1), 1 green and 1 white (row 0, BGR): green wins.
  EXPECT_EQ(table.classifyBlock(bgr_view, 0, 0, 2), ColourClass::kGreen);
  EXPECT_EQ(table.classifyBlock(bgr_view, 2, 1, 4), ColourClass::kWhite);  // clipped at the edge
  EXPECT_EQ(table.classifyBlock(bgr_view, 10, 10, 4), ColourClass::kUnknown);
}

TEST(ColourTable, ConfigErrorsNameFileAndKey) {
  auto load = [](const std::string& yaml) {
    return loadColourTable(config::Node::loadString(yaml, "colours.yaml"));
  };
  EXPECT_NO_THROW(load("colours:\n  green:\n    - {y: [0, 10], u: [0, 10], v: [0, 10]}\n"));
  try {
    load("colours:\n  purple:\n    - {y: [0, 10], u: [0, 10], v: [0, 10]}\n");
    FAIL();
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("colours.yaml:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("purple"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load("colours:\n  green:\n    - {y: [20, 10], u: [0, 10], v: [0, 10]}\n"),
               config::Error);
  EXPECT_THROW(load("colours:\n  green:\n    - {y: [0, 300], u: [0, 10], v: [0, 10]}\n"),
               config::Error);
  EXPECT_THROW(load("colours:\n  green:\n    - {y: [0, 10], u: [0, 10], v: [0, 10], w: 1}\n"),
               config::Error);
}

}  // namespace colour_test
}  // namespace fieldline::camera
