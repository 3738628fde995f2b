// Session 14: the ball class learned from frames under a colour cast with sensor noise (venue case
// colour_cast) must not take in the colours of a line's edge on the carpet. A ball lying on a line
// joins the line's pixels beside it to its blob; learned as ball colours they widened the ball's
// cone over the mixtures of carpet and line (edge pixels; in YUYV two neighbouring pixels share
// one chroma), and the ball detector refused a ball on a line for the long blob those pixels made.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "common/camera/colour.hpp"
#include "common/config/config.hpp"
#include "common/config/paths.hpp"
#include "tools/colour_calibrate/image_calibration.hpp"
#include "tools/eval_real/venue_cases.hpp"

namespace fieldline::calibration {
namespace {

using camera::ColourClass;

std::uint8_t level(double x) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.0, 255.0)));
}

TEST(BallOnALine, TheBallClassKeepsOutTheMixturesOfCarpetAndLineUnderACast) {
  const venue::RenderedVenue v = venue::renderVenue(
      venue::loadVenueCase(config::projectRoot() + "/tests/data/venue_cases/colour_cast.yaml"));
  std::vector<camera::FrameView> views;
  for (std::size_t i = 0; i < v.frames.size(); ++i)
    views.push_back(v.view(i));
  const FramesCalibration c = calibrateColours(v.mirror, v.field, views, ImageFitParams{});
  ASSERT_TRUE(c.calibration.ball_found);
  // The line's pixels beside the ball joined its blobs: left out of its class, and counted.
  EXPECT_GT(c.calibration.ball_samples_refused, 0);
  EXPECT_GE(c.calibration.samples.ball.size(), 5u);
  const camera::ColourTable& table = c.calibration.table;

  // The ball's own image stays ball class: the pixel at its centre in every frame that shows it.
  int shown = 0, orange = 0;
  for (std::size_t i = 0; i < v.frames.size(); ++i) {
    if (!v.frames[i].ball_pixel) continue;
    ++shown;
    const int u = static_cast<int>(std::lround(v.frames[i].ball_pixel->x()));
    const int vv = static_cast<int>(std::lround(v.frames[i].ball_pixel->y()));
    orange += table.classifyPixel(views[i], u, vv) == ColourClass::kOrange ? 1 : 0;
  }
  ASSERT_GT(shown, 0);
  EXPECT_GE(orange, shown - 1);

  // Carpet and line mixed: luma anywhere from the carpet's to the line's, chroma anywhere on the
  // way from the carpet's to the white point (the two need not mix in the same share in YUYV).
  const auto& floor = c.calibration.floor.median;
  const auto& white = c.calibration.white_point;
  const double lineY = c.calibration.line_luma[1];
  int mixtures = 0, ball = 0;
  for (double ty = 0.0; ty <= 1.0 + 1e-9; ty += 0.125) {
    for (double tc = 0.0; tc <= 1.0 + 1e-9; tc += 0.125) {
      const double y = floor[0] + ty * (lineY - floor[0]);
      const double u = floor[1] + tc * (white[0] - floor[1]);
      const double w = floor[2] + tc * (white[1] - floor[2]);
      ++mixtures;
      if (table.classifyYuv(level(y), level(u), level(w)) == ColourClass::kOrange) {
        ++ball;
        ADD_FAILURE() << "carpet/line mixture Y " << y << " U " << u << " V " << w
                      << " is ball class";
      }
    }
  }
  EXPECT_EQ(ball, 0) << "of " << mixtures;
}

}  // namespace
}  // namespace fieldline::calibration
