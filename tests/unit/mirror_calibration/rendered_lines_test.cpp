// Mirror calibration from field lines (mode (a)): frames rendered by the simulated camera at
// known poses through a mirror with a moved centre and an axis offset, calibrated from the plain
// preset.
#include <cstdio>

#include <gtest/gtest.h>

#include "services/camera/camera_config.hpp"
#include "tools/colour_calibrate/evaluation.hpp"
#include "tools/mirror_calibrate/evaluation.hpp"

namespace fieldline::calibration {
namespace {

struct LineCase {
  Vec2 centre_shift;
  Vec2 offset;
  const char* realism;
};

class RenderedLines : public ::testing::TestWithParam<LineCase> {};

TEST_P(RenderedLines, RecoversCentreOffsetAndDistances) {
  const LineCase& c = GetParam();
  const camera::CameraConfig config = camera::loadCameraConfigPreset("omni_sim");
  const camera::MirrorParams base = config.model.mirror.params();
  camera::MirrorParams t = base;
  t.centre += c.centre_shift;
  t.axis_offset = c.offset;
  const camera::MirrorModel truth(t);
  const field::FieldModel field = field::loadFieldPreset("msl");
  const std::vector<geometry::Pose2> poses{
      {-6.0, 1.5, 0.4}, {0.5, 0.8, 0.3}, {-3.5, -2.5, 2.0}, {4.0, 3.0, -1.0}};
  const std::vector<PosedImage> frames =
      renderFieldFrames(truth, field, *config.render, poses, realismSetting(c.realism).realism);
  const LineCalibration cal = calibrateFromLines(frames, field, base, {});
  const MirrorError e = compareMirrors(truth, camera::MirrorModel(cal.mirror), 5.0);
  std::printf(
      "lines %-6s shift (%.1f, %.1f) px offset (%.2f, %.2f) m: centre %.2f px, offset "
      "%.2f cm, distance up to 5 m %.2f %%, %d points, rms %.2f px / %.1f cm\n",
      c.realism, c.centre_shift.x(), c.centre_shift.y(), c.offset.x(), c.offset.y(), e.centre_px,
      100 * e.offset_m, e.distance_percent, cal.points, cal.total.rms_px, cal.total.rms_cm);
  EXPECT_LT(e.centre_px, 1.0);
  EXPECT_LT(e.offset_m, 0.01);
  EXPECT_LT(e.distance_percent, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Settings, RenderedLines,
                         ::testing::Values(LineCase{{2.0, -1.5}, {0.06, -0.04}, "clean"},
                                           LineCase{{-1.5, 2.0}, {-0.08, 0.05}, "all"}));

}  // namespace
}  // namespace fieldline::calibration
