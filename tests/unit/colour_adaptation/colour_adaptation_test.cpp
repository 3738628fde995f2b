// Staying calibrated (issue 12, part 2): the table under a light gain moves green and white
// with the light and leaves the other classes; the adapter follows the tracked green's luma
// slowly, stays within its bounds, skips frames with too little green, and returns to the
// calibration on reset.
#include "services/region_tracking/colour_adaptation.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace fieldline::region_tracking {
namespace colour_adaptation_test {

using camera::ColourClass;

camera::ColourTable calibratedTable() {
  return camera::ColourTable({
      {ColourClass::kGreen, {50, 120}, {100, 124}, {100, 124}},
      {ColourClass::kWhite, {170, 255}, {116, 140}, {116, 140}},
      {ColourClass::kOrange, {60, 200}, {60, 110}, {160, 230}},
  });
}

// A colour under `gain` times the light, plus a colour cast (cu, cv) that does not scale.
camera::Yuv darkened(camera::Yuv c, double gain, int cu = 0, int cv = 0) {
  auto scale = [gain](int level, double grey) {
    return static_cast<std::uint8_t>(std::lround(grey + (level - grey) * gain));
  };
  return {scale(c.y, 0), static_cast<std::uint8_t>(scale(c.u, 128) + cu),
          static_cast<std::uint8_t>(scale(c.v, 128) + cv)};
}

// The carpet's median colour as the tracker would measure it.
GreenStatistics carpetSeen(camera::Yuv c, int samples = 500) {
  return {double(c.y), double(c.u), double(c.v), samples};
}

TEST(ColourAdaptation, UnderGainOneTheTableIsTheCalibration) {
  const camera::ColourTable calibrated = calibratedTable();
  const camera::ColourTable same = tableUnderLight(calibrated, 1.0);
  EXPECT_EQ(same.yuvLookup(), calibrated.yuvLookup());
}

TEST(ColourAdaptation, GreenAndWhiteFollowTheLightOtherClassesStay) {
  const camera::ColourTable calibrated = calibratedTable();
  const camera::ColourTable dark = tableUnderLight(calibrated, 0.5);
  const camera::Yuv carpet{90, 112, 110}, paint{220, 128, 128}, ball{120, 80, 200};
  ASSERT_EQ(calibrated.classifyYuv(carpet), ColourClass::kGreen);
  ASSERT_EQ(calibrated.classifyYuv(paint), ColourClass::kWhite);
  // At half the light the calibrated table loses carpet and paint; the adapted one keeps them.
  EXPECT_NE(calibrated.classifyYuv(darkened(carpet, 0.5)), ColourClass::kGreen);
  EXPECT_NE(calibrated.classifyYuv(darkened(paint, 0.5)), ColourClass::kWhite);
  EXPECT_EQ(dark.classifyYuv(darkened(carpet, 0.5)), ColourClass::kGreen);
  EXPECT_EQ(dark.classifyYuv(darkened(paint, 0.5)), ColourClass::kWhite);
  // BGR input goes through the same adapted classes.
  EXPECT_EQ(dark.classifyBgr(camera::bgrFromYuv(darkened(carpet, 0.5))), ColourClass::kGreen);
  // The ball's colour is where the calibration put it; the old green is no longer green.
  EXPECT_EQ(dark.classifyYuv(ball), ColourClass::kOrange);
  EXPECT_NE(dark.classifyYuv(carpet), ColourClass::kGreen);
  EXPECT_THROW((void)tableUnderLight(calibrated, 0.0), std::invalid_argument);
  EXPECT_THROW((void)tableUnderLight(calibrated, NAN), std::invalid_argument);
}

TEST(ColourAdaptation, UnderAColourCastTheDifferencesToTheCarpetHold) {
  const camera::ColourTable calibrated = calibratedTable();
  const camera::Yuv carpet{90, 112, 110}, paint{220, 128, 128};
  // Half the light and a cast of (+8, +10) that does not scale with it.
  const camera::Yuv carpetNow = darkened(carpet, 0.5, 8, 10);
  const camera::ColourTable adapted =
      tableUnderLight(calibrated, 0.5, {112.0, 110.0}, {double(carpetNow.u), double(carpetNow.v)});
  EXPECT_EQ(adapted.classifyYuv(carpetNow), ColourClass::kGreen);
  EXPECT_EQ(adapted.classifyYuv(darkened(paint, 0.5, 8, 10)), ColourClass::kWhite);
  // Scaled around grey instead, the cast pushes the paint out of white.
  const camera::ColourTable aroundGrey = tableUnderLight(calibrated, 0.5);
  EXPECT_NE(aroundGrey.classifyYuv(darkened(paint, 0.5, 8, 10)), ColourClass::kWhite);
}

TEST(ColourAdaptation, FollowsTheLightSlowlyWithinItsBoundsAndResets) {
  const camera::ColourTable calibrated = calibratedTable();
  camera::ColourTable table = calibrated;
  ColourAdaptationParams params;
  params.enabled = true;
  params.reference_frames = 5;
  params.smoothing = 0.1;
  params.min_samples = 100;
  ColourAdaptation adaptation(calibrated, params);
  const camera::Yuv carpet{90, 112, 110};
  for (int i = 0; i < 5; ++i)
    EXPECT_FALSE(adaptation.observe(carpetSeen(carpet), table));
  EXPECT_TRUE(adaptation.hasReference());
  EXPECT_DOUBLE_EQ(adaptation.gain(), 1.0);

  // The light halves: one frame moves the followed gain a tenth of the way (in log).
  const GreenStatistics half = carpetSeen(darkened(carpet, 0.5));
  adaptation.observe(half, table);
  EXPECT_NEAR(adaptation.gain(), std::exp(0.1 * std::log(0.5)), 1e-9);
  int rebuilds = 0;
  for (int i = 0; i < 100; ++i)
    rebuilds += adaptation.observe(half, table) ? 1 : 0;
  EXPECT_NEAR(adaptation.gain(), 0.5, 0.01);
  EXPECT_GT(rebuilds, 3);
  EXPECT_NEAR(adaptation.appliedGain(), 0.5, 0.5 * params.rebuild_step + 0.01);
  EXPECT_EQ(table.classifyYuv(darkened({90, 112, 110}, 0.5)), ColourClass::kGreen);
  EXPECT_FALSE(adaptation.atBound());

  // Frames with too little green in view say nothing about the light.
  EXPECT_FALSE(adaptation.observe(carpetSeen({5, 128, 128}, 50), table));
  EXPECT_EQ(adaptation.framesSkipped(), 1);
  EXPECT_NEAR(adaptation.gain(), 0.5, 0.01);

  // Near darkness: the gain stops at its bound.
  for (int i = 0; i < 200; ++i)
    adaptation.observe(carpetSeen({4, 126, 126}), table);
  EXPECT_NEAR(adaptation.gain(), params.min_gain, 1e-9);
  EXPECT_TRUE(adaptation.atBound());

  adaptation.reset(table);
  EXPECT_EQ(table.yuvLookup(), calibrated.yuvLookup());
  EXPECT_FALSE(adaptation.hasReference());
  EXPECT_DOUBLE_EQ(adaptation.gain(), 1.0);
}

TEST(ColourAdaptation, AGivenReferenceIsTheCalibrationLightFromTheFirstFrame) {
  const camera::ColourTable calibrated = calibratedTable();
  camera::ColourTable table = calibrated;
  ColourAdaptationParams params;
  params.enabled = true;
  params.smoothing = 1.0;  // follow at once
  params.min_samples = 100;
  const camera::Yuv carpet{90, 112, 110};
  params.reference = std::array<double, 3>{90, 112, 110};
  ColourAdaptation adaptation(calibrated, params);
  EXPECT_TRUE(adaptation.hasReference());
  // The robot starts in half the light: the first frame already moves the table.
  EXPECT_TRUE(adaptation.observe(carpetSeen(darkened(carpet, 0.5)), table));
  EXPECT_NEAR(adaptation.gain(), 0.5, 0.01);
  EXPECT_EQ(table.classifyYuv(darkened(carpet, 0.5)), ColourClass::kGreen);
  adaptation.reset(table);
  EXPECT_TRUE(adaptation.hasReference());
  EXPECT_EQ(table.yuvLookup(), calibrated.yuvLookup());
  const ColourAdaptationParams loaded = loadColourAdaptationParams(
      config::Node::loadString("enabled: true\nreference: [90, 112, 110]\n"));
  ASSERT_TRUE(loaded.reference);
  EXPECT_DOUBLE_EQ((*loaded.reference)[1], 112.0);
  EXPECT_THROW(loadColourAdaptationParams(
                   config::Node::loadString("enabled: true\nreference: [0, 112, 110]\n")),
               config::Error);
}

TEST(ColourAdaptation, BadParametersAreRefused) {
  ColourAdaptationParams p;
  p.min_gain = 1.5;
  EXPECT_THROW(ColourAdaptation(calibratedTable(), p), std::invalid_argument);
  const config::Node good = config::Node::loadString("enabled: true\nmax_gain: 3.0\n");
  const ColourAdaptationParams loaded = loadColourAdaptationParams(good);
  EXPECT_TRUE(loaded.enabled);
  EXPECT_DOUBLE_EQ(loaded.max_gain, 3.0);
  EXPECT_THROW(loadColourAdaptationParams(config::Node::loadString("enabled: true\nspeed: 2\n")),
               config::Error);
  EXPECT_THROW(loadColourAdaptationParams(config::Node::loadString("max_gain: 3.0\n")),
               config::Error);
}

}  // namespace colour_adaptation_test
}  // namespace fieldline::region_tracking
