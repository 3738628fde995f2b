// The ball detector on rendered frames (msl field, omni_sim camera): a ball is accepted only when
// its size and shape fit a ball at its distance and it lies on the carpet, and the best
// candidate wins, not the largest orange region.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "common/geometry/geometry.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/eval_ball/ball_evaluation.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace {

using camera::Vec2;

const camera::Bgr kOrange{10, 100, 240};
const camera::Bgr kRed{40, 40, 200};

class BallDetectorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { sim_ = new SimCamera(SimCamera::load("omni_sim", "msl")); }
  static void TearDownTestSuite() {
    delete sim_;
    sim_ = nullptr;
  }

  VisionResult track(const camera::SimScene& scene, int frames = 3) {
    FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
    return sim_->track(processor, scene, frames);
  }

  static SimCamera* sim_;
};
SimCamera* BallDetectorTest::sim_ = nullptr;

TEST_F(BallDetectorTest, ExpectedSizeShrinksWithDistanceAndMatchesTheRenderedBall) {
  const BallDetector detector(sim_->table, sim_->mirror, BallParams{});
  double previous = 1e9;
  for (const double d : {0.6, 1.0, 2.0, 3.0, 4.0}) {
    double radial = 0, tangential = 0;
    ASSERT_TRUE(detector.expectedExtent(d, 0.3, radial, tangential)) << d;
    EXPECT_LT(tangential, previous) << d;
    previous = tangential;
    EXPECT_GT(radial, 0.5) << d;
  }
  // At 1 m the rendered ball's orange pixels span what the model says, within 1.5 px.
  const geometry::Pose2 pose{0.0, -2.0, 0.0};
  camera::SimScene scene;
  scene.robot = pose;
  scene.ball = camera::SimBall{geometry::pointRobotToField(pose, Vec2(1.0, 0.0)), 0.11};
  const VisionResult result = track(scene);
  ASSERT_TRUE(result.ball.visible);
  double radial = 0, tangential = 0;
  ASSERT_TRUE(detector.expectedExtent(1.0, 0.0, radial, tangential));
  const double expectedArea = 3.14159 / 4 * (radial + 1) * (tangential + 1);
  EXPECT_NEAR(result.ball.pixels / expectedArea, 1.0, 0.4)
      << result.ball.pixels << " px, expected " << expectedArea;
}

TEST_F(BallDetectorTest, TheBallWinsOverALargerOrangeObject) {
  // The robot near the touch line; an orange box on the carpet beyond the line, larger than the
  // ball (the old detector took the largest orange region), and the ball on the field.
  const geometry::Pose2 pose{1.0, 4.8, 0.0};
  camera::SimScene scene;
  scene.robot = pose;
  const Vec2 ballInRobot(-0.5, -1.8);
  scene.ball = camera::SimBall{geometry::pointRobotToField(pose, ballInRobot), 0.11};
  scene.boxes.push_back(standingBox(Vec2(2.5, 7.6), 0.5, 0.5, 0.6, kOrange));
  const VisionResult result = track(scene);
  ASSERT_TRUE(result.ball.visible);
  EXPECT_LE((Vec2(result.ball.x, result.ball.y) - ballInRobot).norm(), 0.05);
  EXPECT_GE(result.ball.candidates, 2);
  EXPECT_GE(result.ball.rejected, 1);
}

TEST_F(BallDetectorTest, OrangeObjectsAndRedPeopleOffTheFieldAreNoBall) {
  const geometry::Pose2 pose{-2.0, 4.5, 1.0};
  camera::SimScene scene;
  scene.robot = pose;
  // The touch line is at y = 7 m, the carpet ends at 8 m.
  scene.boxes.push_back(standingBox(Vec2(-1.0, 7.5), 0.4, 0.4, 0.5, kOrange));
  scene.boxes.push_back(standingBox(Vec2(-3.5, 8.3), 0.6, 0.3, 0.3, kOrange));
  scene.boxes.push_back(standingBox(Vec2(0.0, 7.8), 0.45, 0.3, 1.7, kRed));
  scene.boxes.push_back(standingBox(Vec2(-4.0, 7.6), 0.45, 0.3, 1.8, kRed));
  for (int frames : {1, 3, 10}) {
    const VisionResult result = track(scene, frames);
    EXPECT_FALSE(result.ball.visible) << "at (" << result.ball.x << ", " << result.ball.y << ")";
  }
}

TEST_F(BallDetectorTest, RefusesCandidatesOfTheWrongSizeAndOffTheCarpet) {
  // An orange box the size of a person lying on the carpet: too large for a ball anywhere.
  const geometry::Pose2 pose{0.0, 0.0, 0.0};
  camera::SimScene scene;
  scene.robot = pose;
  scene.boxes.push_back(standingBox(Vec2(1.5, 0.0), 0.3, 1.2, 0.3, kOrange));
  const VisionResult result = track(scene);
  EXPECT_FALSE(result.ball.visible);
  EXPECT_GE(result.ball.rejected, 1);
}

TEST_F(BallDetectorTest, WithFusionsPoseABallBeyondTheLinesIsNoBall) {
  // The touch line's centre is at y = 7 m, the carpet ends at 8 m: a ball at y = 7.6 m lies on
  // the carpet but 0.5 m beyond the line's outer edge. By the image alone it is a ball; with the
  // field and fusion's pose (2 cm sure) it is out (issue 30: no ball outside the field).
  const geometry::Pose2 pose{-2.0, 6.0, 0.0};
  camera::SimScene scene;
  scene.robot = pose;
  scene.ball = camera::SimBall{Vec2(-1.5, 7.6), 0.11};
  const VisionResult alone = track(scene);
  ASSERT_TRUE(alone.ball.visible) << "the image alone sees it";

  FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
  processor.setBallRegion(BallRegion{&sim_->field, pose, 0.02});
  const VisionResult out = sim_->track(processor, scene);
  EXPECT_FALSE(out.ball.visible) << "at (" << out.ball.x << ", " << out.ball.y << ")";
  EXPECT_GE(out.ball.rejected, 1);

  // The same ball 0.4 m inside the line: a ball, with or without the field.
  scene.ball = camera::SimBall{Vec2(-1.5, 6.6), 0.11};
  FrameProcessor inside(sim_->mirror, sim_->table, defaultVisionParams());
  inside.setBallRegion(BallRegion{&sim_->field, pose, 0.02});
  const VisionResult in = sim_->track(inside, scene);
  ASSERT_TRUE(in.ball.visible);
  const Vec2 truth = geometry::pointFieldToRobot(pose, Vec2(-1.5, 6.6));
  EXPECT_LE((Vec2(in.ball.x, in.ball.y) - truth).norm(), 0.05);
}

TEST_F(BallDetectorTest, ABallsBearingWhileTheRobotTurnsIsWithinAFractionOfItsSigma) {
  // Issue 34 item 1: in live matches a sighting's bearing was off by 2.5-7 times the detector's
  // tangential sigma. Frames rendered at the pose they are stamped with, the detector is not the
  // cause: at 2-5 m, standing or turning at up to 3 rad/s (the tracker following the ball from
  // frame to frame, 0.1 rad a frame), the bearing error is about a quarter of the sigma.
  for (const double range : {2.0, 3.5, 5.0}) {
    for (const double omega : {0.0, 3.0}) {
      FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
      VisionResult out;
      const geometry::Vec2 ball(1.0 + range * std::cos(0.3), 0.5 + range * std::sin(0.3));
      double squares = 0, sigmas = 0;
      int found = 0;
      for (int i = 0; i < 150; ++i) {
        camera::SimScene scene;
        // Standing: the heading still moves a little from frame to frame (other pixels).
        scene.robot = {1.0, 0.5,
                       geometry::normalizeAngle(omega > 0 ? omega * i / 30.0 : 0.0123 * i)};
        scene.omega = omega;
        scene.frame_number = static_cast<std::uint64_t>(i);
        scene.ball = camera::SimBall{ball, 0.11};
        processor.process(sim_->render(scene), i % 3 == 0, out);
        if (!out.ball.visible) continue;
        const Vec2 truth = geometry::pointFieldToRobot(scene.robot, ball);
        const double e = geometry::angleDiff(std::atan2(out.ball.y, out.ball.x),
                                             std::atan2(truth.y(), truth.x()));
        squares += e * e;
        sigmas += out.ball.sigma_tangential / truth.norm();
        ++found;
      }
      ASSERT_GT(found, 50) << range << " m, " << omega << " rad/s";
      const double rms = std::sqrt(squares / found);
      EXPECT_LT(rms, 0.5 * sigmas / found) << range << " m, " << omega << " rad/s";
      EXPECT_LT(rms, 0.002) << range << " m, " << omega << " rad/s";
    }
  }
}

// A YUYV frame of the mirror model's view of a green carpet with a ball (centre `inRobot`, robot
// frame, `radius` up): a pixel is orange when the ray from R through its centre meets the sphere
// (the model's 3-D projection), and each two neighbouring pixels share their chroma (YUYV 4:2:2,
// what the camera delivers). No renderer: shading, texture, noise and light play no part.
std::vector<std::uint8_t> sphereFrame(const camera::MirrorModel& m, const Vec2& inRobot,
                                      double radius) {
  const camera::Yuv carpet = camera::yuvFromBgr({38, 102, 34});
  const camera::Yuv ball = camera::yuvFromBgr({8, 85, 204});
  const camera::Yuv dark = camera::yuvFromBgr({28, 28, 28});
  const double H = m.params().reference_height;
  const camera::Vec3 centre(m.robotToAxis(inRobot).x(), m.robotToAxis(inRobot).y(), radius);
  const camera::Vec3 w0 = camera::Vec3(0, 0, H) - centre;
  std::vector<std::uint8_t> yuyv(static_cast<std::size_t>(2 * m.width() * m.height()));
  for (int v = 0; v < m.height(); ++v) {
    for (int u = 0; u < m.width(); u += 2) {
      camera::Yuv c[2];
      for (int k = 0; k < 2; ++k) {
        const std::optional<Vec2> floor = m.imageToAxis(Vec2(u + k, v));
        c[k] = floor ? carpet : dark;
        if (!floor) continue;
        const camera::Vec3 dir(floor->x(), floor->y(), -H);
        const double bh = dir.dot(w0);
        if (bh * bh - dir.squaredNorm() * (w0.squaredNorm() - radius * radius) >= 0) c[k] = ball;
      }
      std::uint8_t* out = &yuyv[static_cast<std::size_t>(v * 2 * m.width() + 2 * u)];
      out[0] = c[0].y;
      out[1] = static_cast<std::uint8_t>((c[0].u + c[1].u + 1) / 2);
      out[2] = c[1].y;
      out[3] = static_cast<std::uint8_t>((c[0].v + c[1].v + 1) / 2);
    }
  }
  return yuyv;
}

TEST_F(BallDetectorTest, AFarBallProjectedThroughTheMirrorModelComesBackAtItsRange) {
  // Issue 34 (session 14): far resting balls' sightings were read too far, +2 cm at 4-5 m and
  // +4 cm at 5-6 m in live matches. Cause: beyond about 4.2 m the ball's far edge lies beyond the
  // useful radius, so the detector places it by its near edge alone, taking the silhouette's edge
  // half a pixel inside the nearest orange pixel centre; with YUYV's shared chroma an edge pixel
  // whose pair partner is carpet is no longer orange, and the edge lies 0.6-1.0 px inside. A
  // sphere projected through the model (no renderer) at 4.4-5.3 m, 12 bearings (68 seen): the
  // radial error's mean was +5.1 cm with the half-pixel rule, +1.4 cm with the model's edge
  // insets (these balls' nearest orange pixels lie 0.92 px in on average, the table's average
  // over all sub-pixel places says 0.81).
  const camera::MirrorModel& m = sim_->mirror;
  // One processor (its edge-inset table is built at construction: tens of ms); three frames of
  // each ball, so the tracker has grown onto it before the one that counts.
  FrameProcessor processor(m, sim_->table, defaultVisionParams());
  double sum = 0;
  int found = 0, tried = 0;
  for (double range = 4.4; range < 5.35; range += 0.1) {
    for (int k = 0; k < 12; ++k) {
      const double bearing = 0.1 + k * std::numbers::pi / 6 + 0.37 * range;
      const Vec2 inRobot = range * Vec2(std::cos(bearing), std::sin(bearing));
      const std::vector<std::uint8_t> frame = sphereFrame(m, inRobot, 0.11);
      const camera::FrameView view{frame.data(), m.width(), m.height(), 2 * m.width(),
                                   camera::PixelFormat::kYuyv};
      VisionResult out;
      for (int i = 0; i < 3; ++i)
        processor.process(view, false, out);
      ++tried;
      if (!out.ball.visible) continue;
      const double error = Vec2(out.ball.x, out.ball.y).norm() - range;
      ASSERT_LT(std::abs(error), 0.3) << range << " m, bearing " << bearing;
      sum += error;
      ++found;
    }
  }
  ASSERT_GT(found, tried / 4);
  std::printf("%d of %d balls found, mean radial error %.4f m\n", found, tried, sum / found);
  EXPECT_LT(std::abs(sum / found), 0.025) << "mean radial error over " << found << " balls";
}

TEST_F(BallDetectorTest, ATableWithoutTheBallColourSeesNoBall) {
  // The ball's colour comes from the calibration (the table's orange cells): a table that has
  // none (no ball was found when it was made) finds no ball, and says so.
  std::vector<camera::YuvBox> boxes;
  for (const camera::YuvBox& box : sim_->table.boxes()) {
    if (box.colour != camera::ColourClass::kOrange) boxes.push_back(box);
  }
  const camera::ColourTable without(boxes);
  EXPECT_TRUE(BallDetector(sim_->table, sim_->mirror, BallParams{}).hasBallColour());
  EXPECT_FALSE(BallDetector(without, sim_->mirror, BallParams{}).hasBallColour());
  const geometry::Pose2 pose{0.0, -2.0, 0.0};
  camera::SimScene scene;
  scene.robot = pose;
  scene.ball = camera::SimBall{geometry::pointRobotToField(pose, Vec2(1.0, 0.0)), 0.11};
  FrameProcessor processor(sim_->mirror, without, defaultVisionParams());
  EXPECT_FALSE(sim_->track(processor, scene).ball.visible);
  EXPECT_TRUE(track(scene).ball.visible);
}

TEST(BallParamsTest, InvalidParametersAreRefused) {
  const SimCamera sim = SimCamera::load("omni_sim", "msl");
  auto with = [&](auto change) {
    BallParams p;
    change(p);
    return [&sim, p] { BallDetector d(sim.table, sim.mirror, p); };
  };
  EXPECT_THROW(with([](BallParams& p) { p.size_tolerance = 0.9; })(), std::invalid_argument);
  EXPECT_THROW(with([](BallParams& p) { p.min_fill = 1.5; })(), std::invalid_argument);
  EXPECT_THROW(with([](BallParams& p) { p.min_carpet_share = -0.1; })(), std::invalid_argument);
  EXPECT_THROW(with([](BallParams& p) { p.centre_height = 0.0; })(), std::invalid_argument);
  EXPECT_NO_THROW(with([](BallParams&) {})());
}

TEST(BallEvaluation, ScenesAreDeterministicAndTheBallRollsOnTheField) {
  const SimCamera sim = SimCamera::load("omni_sim", "msl");
  const eval_ball::BallEvalOptions options;
  const int frames = 600;
  const std::vector<geometry::Pose2> poses =
      motionPoses(sim.field, Motion{.speed = 1.0, .omega = 0.4}, frames);
  const std::vector<Vec2> balls = eval_ball::ballPath(options, sim.field, poses);
  ASSERT_EQ(balls, eval_ball::ballPath(options, sim.field, poses));
  double travelled = 0;
  for (int frame = 0; frame < frames; ++frame) {
    const Vec2& ball = balls[static_cast<std::size_t>(frame)];
    EXPECT_LT(std::abs(ball.x()), sim.field.length() / 2);
    EXPECT_LT(std::abs(ball.y()), sim.field.width() / 2);
    if (frame > 0) {
      const double step = (ball - balls[static_cast<std::size_t>(frame - 1)]).norm();
      EXPECT_LE(step, options.max_ball_speed / 30.0 + 1e-9);
      travelled += step;
    }
    if (frame % 7 != 0) continue;
    const camera::SimScene a = eval_ball::sceneFor(options, sim.field, poses, balls, frame);
    const camera::SimScene b = eval_ball::sceneFor(options, sim.field, poses, balls, frame);
    ASSERT_TRUE(a.ball.has_value());
    ASSERT_EQ(a.boxes.size(), b.boxes.size());
    EXPECT_EQ(a.boxes.size(), 5u);
    // Clutter stays off the field's lines.
    for (const camera::SimBox& c : a.boxes) {
      const Vec2 mid(0.5 * (c.lo.x() + c.hi.x()), 0.5 * (c.lo.y() + c.hi.y()));
      EXPECT_EQ(c.lo, b.boxes[&c - a.boxes.data()].lo);
      EXPECT_TRUE(std::abs(mid.x()) > sim.field.length() / 2 + 0.3 ||
                  std::abs(mid.y()) > sim.field.width() / 2 + 0.3);
    }
  }
  EXPECT_GT(travelled, 5.0);  // it rolls
}

}  // namespace
}  // namespace fieldline::region_tracking
