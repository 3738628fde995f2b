// The must-show of issue 12, part 3: mirror calibration from one rendered ring-carpet frame
// recovers the distance function within 2 % up to 5 m, the mirror centre within 1 px and the
// axis offset within 1 cm, for several centre/offset settings and with the realism knobs on.
#include <gtest/gtest.h>

#include "tools/colour_calibrate/evaluation.hpp"
#include "tools/mirror_calibrate/evaluation.hpp"

namespace fieldline::calibration {
namespace rendered_rings_test {

struct Case {
  Vec2 centre_shift;
  Vec2 offset;
  const char* realism;
};

class RenderedRings : public ::testing::TestWithParam<Case> {};

TEST_P(RenderedRings, RecoversCentreOffsetAndDistances) {
  const Case& c = GetParam();
  const camera::MirrorParams base = camera::loadCameraPreset("omni_sim").mirror.params();
  camera::MirrorParams t = base;
  t.centre += c.centre_shift;
  t.axis_offset = c.offset;
  const camera::MirrorModel truth(t);
  const RingCarpet carpet;
  const GreyImage image = renderRingCarpet(truth, carpet, realismSetting(c.realism).realism, 0);
  RingCalibrationParams params;
  params.search.min_radius = base.self_radius;
  params.search.max_radius = base.outer_radius;
  // Starts from the preset (centre and offset unknown).
  const RingCalibration cal = calibrateFromRings(image, carpet.distances, base, params);
  EXPECT_EQ(cal.match.first_distance, 0);
  const MirrorError e = compareMirrors(truth, camera::MirrorModel(cal.mirror), 5.0);
  RecordProperty("centre_px", std::to_string(e.centre_px));
  RecordProperty("offset_cm", std::to_string(100 * e.offset_m));
  RecordProperty("distance_percent", std::to_string(e.distance_percent));
  std::printf(
      "%-6s shift (%.1f, %.1f) px offset (%.2f, %.2f) m: centre %.2f px, offset %.2f cm, "
      "distance up to 5 m %.2f %%, table rms %.2f px\n",
      c.realism, c.centre_shift.x(), c.centre_shift.y(), c.offset.x(), c.offset.y(), e.centre_px,
      100 * e.offset_m, e.distance_percent, cal.table.total.rms_px);
  EXPECT_LT(e.centre_px, 1.0);
  EXPECT_LT(e.offset_m, 0.01);
  EXPECT_LT(e.distance_percent, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Settings, RenderedRings,
                         ::testing::Values(Case{{0.0, 0.0}, {0.0, 0.0}, "clean"},
                                           Case{{2.5, -1.5}, {0.06, -0.04}, "clean"},
                                           Case{{-3.0, 2.0}, {-0.10, 0.05}, "noise"},
                                           Case{{2.5, -1.5}, {0.06, -0.04}, "blur"},
                                           Case{{1.5, 2.5}, {0.03, 0.08}, "uneven"},
                                           Case{{-2.0, -2.0}, {0.12, 0.0}, "all"},
                                           Case{{2.5, -1.5}, {0.06, -0.04}, "all"}));

}  // namespace rendered_rings_test
}  // namespace fieldline::calibration
