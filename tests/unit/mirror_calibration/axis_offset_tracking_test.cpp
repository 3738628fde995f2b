// The mirror axis away from the robot's centre (issue 12, part 3): a frame rendered with an axis
// offset gives line points and a ball on the true field positions when the tracker's camera
// model has the same offset, and visibly wrong ones when it has none.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "common/geometry/geometry.hpp"
#include "services/camera/camera_config.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace {

using camera::Vec2;

class AxisOffsetTracking : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { sim_ = new SimCamera(SimCamera::load("omni_sim", "msl")); }
  static void TearDownTestSuite() {
    delete sim_;
    sim_ = nullptr;
  }

  struct Seen {
    double line_median_m = 0.0;  // median distance of line points to the nearest field line
    int line_points = 0;
    double ball_error_m = -1.0;  // distance of the ball from its true position, -1 if not seen
  };

  // Renders at `pose` with the truth mirror and tracks with `tracker_mirror`.
  static Seen track(const camera::MirrorModel& truth, const camera::MirrorModel& tracker_mirror,
                    const geometry::Pose2& pose, const Vec2& ball) {
    camera::CameraConfig config = camera::loadCameraConfigPreset("omni_sim");
    camera::SimRenderer renderer(truth, sim_->field, *config.render);
    camera::SimScene scene;
    scene.robot = pose;
    scene.ball = camera::SimBall{ball, 0.11};
    std::vector<std::uint8_t> frame;
    FrameProcessor processor(tracker_mirror, sim_->table, defaultVisionParams());
    VisionResult vision;
    for (int i = 0; i < 3; ++i) {
      scene.frame_number = static_cast<std::uint64_t>(i);
      renderer.render(scene, frame);
      processor.process(renderer.view(frame), true, vision);
    }
    Seen seen;
    std::vector<double> d;
    for (const perception::LinePoint& p : vision.lines.points) {
      d.push_back(sim_->field.distance(geometry::pointRobotToField(pose, Vec2(p.x, p.y))));
    }
    seen.line_points = static_cast<int>(d.size());
    if (!d.empty()) {
      std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
      seen.line_median_m = d[d.size() / 2];
    }
    if (vision.ball.visible) {
      seen.ball_error_m =
          (geometry::pointRobotToField(pose, Vec2(vision.ball.x, vision.ball.y)) - ball).norm();
    }
    return seen;
  }

  static SimCamera* sim_;
};

SimCamera* AxisOffsetTracking::sim_ = nullptr;

TEST_F(AxisOffsetTracking, MatchingConfigTracksAndOffsetFreeConfigDoesNot) {
  camera::MirrorParams p = sim_->mirror.params();
  const camera::MirrorModel centred(p);
  for (const Vec2& offset : {Vec2(0.10, -0.06), Vec2(-0.08, 0.09)}) {
    p.axis_offset = offset;
    const camera::MirrorModel withOffset(p);
    for (const geometry::Pose2& pose : {geometry::Pose2{-6.0, 1.5, 0.4}, {0.5, 0.8, 0.3}}) {
      const Vec2 ball = geometry::pointRobotToField(pose, Vec2(1.6, 0.7));
      const Seen right = track(withOffset, withOffset, pose, ball);
      const Seen wrong = track(withOffset, centred, pose, ball);
      std::printf(
          "offset (%.2f, %.2f) pose (%.1f, %.1f): lines median %.1f / %.1f cm (%d / %d "
          "points), ball %.1f / %.1f cm (matching / offset-free config)\n",
          offset.x(), offset.y(), pose.x, pose.y, 100 * right.line_median_m,
          100 * wrong.line_median_m, right.line_points, wrong.line_points, 100 * right.ball_error_m,
          100 * wrong.ball_error_m);
      SCOPED_TRACE(testing::Message()
                   << "offset " << offset.transpose() << " pose " << pose.x << "," << pose.y);
      ASSERT_GT(right.line_points, 50);
      EXPECT_LT(right.line_median_m, 0.025);
      EXPECT_GT(wrong.line_median_m, 0.04);
      ASSERT_GE(right.ball_error_m, 0.0);
      EXPECT_LT(right.ball_error_m, 0.05);
      EXPECT_GT(wrong.ball_error_m, 0.08);
    }
  }
}

// Offset zero is today's model: the same pixels, the same floor points.
TEST_F(AxisOffsetTracking, ZeroOffsetChangesNothing) {
  const camera::MirrorModel& m = sim_->mirror;
  EXPECT_EQ(m.params().axis_offset, Vec2::Zero());
  const Vec2 px(200.0, 90.0);
  EXPECT_EQ(*m.imageToRobot(px), *m.imageToAxis(px));
}

}  // namespace
}  // namespace fieldline::region_tracking
