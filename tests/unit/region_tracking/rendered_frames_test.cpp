// The detectors on frames rendered by the simulated camera at known poses (msl field, omni_sim
// camera, 4x4 cells): line points on the model's lines, the ball, obstacles.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "common/config/config.hpp"
#include "common/geometry/geometry.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace {

using camera::Vec2;

// In the own penalty area, facing the own goal: the goal area about 2.5 m ahead.
constexpr geometry::Pose2 kGoalAreaPose{-8.0, -1.5, M_PI};

class RenderedFrames : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { sim_ = new SimCamera(SimCamera::load("omni_sim", "msl")); }
  static void TearDownTestSuite() {
    delete sim_;
    sim_ = nullptr;
  }

  VisionResult track(FrameProcessor& processor, const camera::SimScene& scene, int frames = 3) {
    return sim_->track(processor, scene, frames);
  }

  static SimCamera* sim_;
};
SimCamera* RenderedFrames::sim_ = nullptr;

double median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// A rendered (YUYV) frame as BGR, its pixels in `pixels`.
camera::FrameView bgrOf(const camera::FrameView& frame, std::vector<std::uint8_t>& pixels) {
  pixels.resize(static_cast<std::size_t>(frame.width) * frame.height * 3);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const camera::Bgr c = camera::bgrFromYuv(camera::readYuv(frame, u, v));
      std::uint8_t* out = &pixels[(static_cast<std::size_t>(v) * frame.width + u) * 3];
      out[0] = c.b;
      out[1] = c.g;
      out[2] = c.r;
    }
  }
  return {pixels.data(), frame.width, frame.height, frame.width * 3, camera::PixelFormat::kBgr};
}

double distanceToSegment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t =
      ab.squaredNorm() > 0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

TEST_F(RenderedFrames, LinePointsLieOnTheModelLinesAndCoverThemWithin3m) {
  const std::vector<geometry::Pose2> poses = {
      {1.0, 0.5, 0.3}, {-2.0, -1.5, 2.0}, {7.5, 0.5, -1.0}, {-6.5, 0.5, 3.0}, {-3.0, 5.0, 0.8}};
  const std::vector<Vec2> modelSamples = sim_->field.sampleLines(0.02);
  for (const geometry::Pose2& pose : poses) {
    FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
    camera::SimScene scene;
    scene.robot = pose;
    const VisionResult result = track(processor, scene);

    // Accuracy: distance of every point within 3 m to the nearest line centre.
    std::vector<double> errors;
    std::vector<Vec2> fieldPoints(result.lines.points.size());
    for (std::size_t i = 0; i < result.lines.points.size(); ++i) {
      const LinePoint& q = result.lines.points[i];
      fieldPoints[i] = geometry::pointRobotToField(pose, Vec2(q.x, q.y));
      if (Vec2(q.x, q.y).norm() <= 3.0) errors.push_back(sim_->field.distance(fieldPoints[i]));
    }
    ASSERT_GE(errors.size(), 20u) << "pose " << pose.x << "," << pose.y;
    const double medianError = median(errors);
    EXPECT_LE(medianError, 0.02) << "pose " << pose.x << "," << pose.y;

    // Coverage: visible model line within 3 m that some sequence passes within 10 cm of.
    int visible = 0, covered = 0;
    for (const Vec2& sample : modelSamples) {
      const Vec2 inRobot = geometry::pointFieldToRobot(pose, sample);
      if (inRobot.norm() > 3.0) continue;
      const std::optional<Vec2> pixel = sim_->mirror.robotToImage(inRobot);
      if (!pixel || sim_->mirror.zone(*pixel) != camera::MirrorZone::kUseful) continue;
      ++visible;
      bool hit = false;
      for (const auto& [first, end] : result.lines.sequences) {
        for (int i = first; i + 1 < end && !hit; ++i) {
          hit = distanceToSegment(sample, fieldPoints[i], fieldPoints[i + 1]) <= 0.10;
        }
        if (hit) break;
      }
      covered += hit ? 1 : 0;
    }
    ASSERT_GT(visible, 100);
    const double coverage = static_cast<double>(covered) / visible;
    EXPECT_GE(coverage, 0.90) << "pose " << pose.x << "," << pose.y;
    std::printf("pose (%.1f, %.1f, %.1f): %zu points, median error %.4f m, coverage %.3f\n", pose.x,
                pose.y, pose.phi, result.lines.points.size(), medianError, coverage);
  }
}

// The detector reads YUYV and BGR frames through separate code paths: the same scene given as
// BGR yields line points of the same accuracy, nearly the same number of them, at the same places.
TEST_F(RenderedFrames, LinePointsFromBgrFramesMatchThoseFromYuyv) {
  const geometry::Pose2 pose{-2.0, -1.5, 2.0};
  camera::SimScene scene;
  scene.robot = pose;
  FrameProcessor yuyvProcessor(sim_->mirror, sim_->table, defaultVisionParams());
  FrameProcessor bgrProcessor(sim_->mirror, sim_->table, defaultVisionParams());
  VisionResult yuyv, bgr;
  std::vector<std::uint8_t> bgrPixels;
  for (int i = 0; i < 3; ++i) {
    scene.frame_number = static_cast<std::uint64_t>(i);
    const camera::FrameView frame = sim_->render(scene);
    yuyvProcessor.process(frame, true, yuyv);
    bgrProcessor.process(bgrOf(frame, bgrPixels), true, bgr);
  }
  auto errors = [&](const LinePoints& lines) {
    std::vector<double> result;
    for (const LinePoint& q : lines.points) {
      if (Vec2(q.x, q.y).norm() > 3.0) continue;
      result.push_back(sim_->field.distance(geometry::pointRobotToField(pose, Vec2(q.x, q.y))));
    }
    return result;
  };
  const std::vector<double> yuyvErrors = errors(yuyv.lines), bgrErrors = errors(bgr.lines);
  ASSERT_GE(yuyvErrors.size(), 20u);
  ASSERT_GE(bgrErrors.size(), 20u);
  EXPECT_LE(median(yuyvErrors), 0.02);
  EXPECT_LE(median(bgrErrors), 0.02);
  const double yuyvCount = static_cast<double>(yuyv.lines.points.size());
  EXPECT_NEAR(static_cast<double>(bgr.lines.points.size()), yuyvCount, 0.1 * yuyvCount);
  // Every BGR point has a YUYV point within a pixel.
  for (const LinePoint& q : bgr.lines.points) {
    double nearest = 1e9;
    for (const LinePoint& p : yuyv.lines.points)
      nearest = std::min(nearest, static_cast<double>(std::hypot(p.u - q.u, p.v - q.v)));
    EXPECT_LE(nearest, 1.0) << q.u << "," << q.v;
  }
}

TEST_F(RenderedFrames, BallIsFoundWithin5cmUpTo4m) {
  const geometry::Pose2 pose{0.5, -1.0, 0.7};
  // Ball positions in the robot frame: near, middle, far, in several directions.
  const std::vector<Vec2> balls = {{0.6, 0.2},   {1.2, -0.8}, {-1.5, 1.0}, {2.0, 1.5},
                                   {-2.5, -1.0}, {0.5, 3.0},  {3.2, -1.5}, {-3.5, 1.5}};
  for (const Vec2& ballInRobot : balls) {
    FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
    camera::SimScene scene;
    scene.robot = pose;
    scene.ball = camera::SimBall{geometry::pointRobotToField(pose, ballInRobot), 0.11};
    const VisionResult result = track(processor, scene);
    ASSERT_TRUE(result.ball.visible) << ballInRobot.transpose();
    const double error = (Vec2(result.ball.x, result.ball.y) - ballInRobot).norm();
    EXPECT_LE(error, 0.05) << ballInRobot.transpose();
    std::printf("ball at %.2f m: error %.3f m, %d px, confidence %.2f\n", ballInRobot.norm(), error,
                result.ball.pixels, result.ball.confidence);
  }
  // No ball, no detection.
  FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
  camera::SimScene empty;
  empty.robot = pose;
  EXPECT_FALSE(track(processor, empty).ball.visible);
}

TEST_F(RenderedFrames, BallKeepsBeingTrackedWhileItRolls) {
  FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
  camera::SimScene scene;
  scene.robot = {0.0, 0.0, 0.0};
  VisionResult result;
  for (int i = 0; i < 30; ++i) {
    const Vec2 ball(1.0 + 0.05 * i, -0.5 + 0.03 * i);  // 1.7 m/s at 30 Hz
    scene.ball = camera::SimBall{ball, 0.11};
    scene.frame_number = static_cast<std::uint64_t>(i);
    processor.process(sim_->render(scene), i % 3 == 0, result);
    ASSERT_TRUE(result.ball.visible) << "frame " << i;
    EXPECT_LE((Vec2(result.ball.x, result.ball.y) - ball).norm(), 0.05) << "frame " << i;
    EXPECT_EQ(result.lines_detected, i % 3 == 0);
  }
}

// The classifier and the line detector read a copy of the table's classes (ClassLookup): a
// table replaced by whoever holds it (the colour adaptation of the node or of
// fieldline-colour-calibrate --adapt) is taken at the next frame without being told.
TEST_F(RenderedFrames, AReplacedColourTableIsTakenAtTheNextFrame) {
  camera::ColourTable table = sim_->table;
  FrameProcessor processor(sim_->mirror, table, defaultVisionParams());
  camera::SimScene scene;
  scene.robot = {0.0, 0.0, 0.0};
  VisionResult result;
  processor.process(sim_->render(scene), true, result);
  ASSERT_GT(result.lines.points.size(), 0u);
  const auto differing = [&] {
    int n = 0;
    for (int y = 0; y < 256; y += 3)
      for (int u = 0; u < 256; u += 3)
        for (int v = 0; v < 256; v += 3) {
          const auto cy = static_cast<std::uint8_t>(y), cu = static_cast<std::uint8_t>(u),
                     cv = static_cast<std::uint8_t>(v);
          n += processor.classLookup().classifyYuv(cy, cu, cv) != table.classifyYuv(cy, cu, cv);
        }
    return n;
  };
  EXPECT_EQ(differing(), 0);
  table = camera::ColourTable();  // everything unknown: no green, no lines
  EXPECT_GT(differing(), 1000);
  processor.process(sim_->render(scene), true, result);
  EXPECT_EQ(differing(), 0);
  EXPECT_EQ(result.lines.points.size(), 0u);
}

// Review 14, L12: for BGR frames the cell classifier reads the table itself, the line detector
// the processor's copy of its classes (ClassLookup). A replaced table reaches both at the next
// frame, so the two never work from different tables: from an empty table to the simulator's,
// the classifier's green and the line points come with the first frame, and both go with the
// first frame after the table is emptied again.
TEST_F(RenderedFrames, ForBgrFramesTheClassifierAndTheLineDetectorTakeAReplacedTableTogether) {
  camera::ColourTable table;  // everything unknown
  FrameProcessor processor(sim_->mirror, table, defaultVisionParams());
  camera::SimScene scene;
  scene.robot = {-2.0, -1.5, 2.0};
  std::vector<std::uint8_t> pixels;
  const camera::FrameView bgr = bgrOf(sim_->render(scene), pixels);
  const auto greenCells = [&] {
    processor.classifier().setFrame(bgr);
    int n = 0;
    for (int y = 0; y < processor.grid().height; ++y) {
      for (int x = 0; x < processor.grid().width; ++x)
        n += processor.classifier().classify(x, y) == classIdOf(camera::ColourClass::kGreen);
    }
    return n;
  };
  VisionResult result;
  processor.process(bgr, true, result);
  EXPECT_EQ(greenCells(), 0);
  EXPECT_EQ(result.lines.points.size(), 0u);
  table = sim_->table;
  processor.process(bgr, true, result);
  EXPECT_GT(greenCells(), 1000);
  EXPECT_GT(result.lines.points.size(), 20u);
  table = camera::ColourTable();
  processor.process(bgr, true, result);
  EXPECT_EQ(greenCells(), 0);
  EXPECT_EQ(result.lines.points.size(), 0u);
}

TEST_F(RenderedFrames, ObstaclesHaveBearingDistanceAndWidth) {
  const geometry::Pose2 pose{-1.0, 0.5, -0.4};
  const std::vector<Vec2> obstacles = {{1.5, 0.8}, {-2.0, -1.5}};
  FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
  camera::SimScene scene;
  scene.robot = pose;
  for (const Vec2& o : obstacles) {
    scene.robots.push_back({geometry::pointRobotToField(pose, o), 0.25, false});
  }
  const VisionResult result = track(processor, scene);
  ASSERT_EQ(result.obstacles.size(), obstacles.size());
  for (const Vec2& truth : obstacles) {
    const double bearing = std::atan2(truth.y(), truth.x());
    const auto found =
        std::min_element(result.obstacles.begin(), result.obstacles.end(),
                         [&](const Obstacle& a, const Obstacle& b) {
                           return std::abs(std::remainder(a.bearing - bearing, 2 * M_PI)) <
                                  std::abs(std::remainder(b.bearing - bearing, 2 * M_PI));
                         });
    EXPECT_NEAR(std::remainder(found->bearing - bearing, 2 * M_PI), 0.0, 0.06);
    EXPECT_NEAR(found->distance, truth.norm() - 0.25, 0.10);
    EXPECT_NEAR(found->width, 0.5, 0.15);
  }
}

// Issue 12 part 6: every green region of at least min_seed_cells is tracked, also the small one
// inside the goal area 2.5 m away (about 3 by 8 cells here). (Whether the seed's cap of the 10
// largest would drop it depends on how many regions the view-edge seeding catches in the same
// frame: region_tracker_test's GreenRegionsAboveTheMinimumSizeAreAllSeeded shows the cap's miss.)
TEST_F(RenderedFrames, TheSmallGreenRegionInsideTheGoalAreaIsTracked) {
  const geometry::Pose2 pose = kGoalAreaPose;
  const field::FieldModel& field = sim_->field;
  // The goal area's middle on the own side, and the cell showing it.
  const Vec2 goal_area_middle(-field.length() / 2 + field.dimensions().goal_area_depth / 2, 0.0);
  const std::optional<Vec2> pixel =
      sim_->mirror.robotToImage(geometry::pointFieldToRobot(pose, goal_area_middle));
  ASSERT_TRUE(pixel.has_value());
  camera::SimScene scene;
  scene.robot = pose;
  FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
  const VisionParams params = defaultVisionParams();
  const ClassId green = classIdOf(camera::ColourClass::kGreen);
  const int cell = params.tracker.cell_size;
  const int cx = static_cast<int>(pixel->x()) / cell, cy = static_cast<int>(pixel->y()) / cell;
  for (int frame = 0; frame < 3; ++frame) {  // the initial search, then tracking
    VisionResult result;
    scene.frame_number = static_cast<std::uint64_t>(frame);
    processor.process(sim_->render(scene), true, result);
    EXPECT_EQ(processor.tracker().ownerOf(cx, cy), green) << "frame " << frame;
  }
  // It is a region of its own (the goal area's lines around it), and one of many in view (13
  // until bias10i's renderer change, 9 since: far lines, interpolated at finer cells, no longer
  // break into pieces that cut off small green patches).
  const std::vector<Contour>& contours = processor.tracker().contours().contours;
  int green_regions = 0;
  for (const Contour& c : contours)
    green_regions += c.outer && c.class_id == green ? 1 : 0;
  EXPECT_GE(green_regions, 8);
  int goal_area_cells = 0;
  const std::vector<ClassId> owners = processor.tracker().visited();
  {
    // Flood the goal area's region from its middle cell to measure it.
    const CellGrid& grid = processor.grid();
    std::vector<std::uint8_t> seen(owners.size(), 0);
    std::vector<Cell> queue{{static_cast<std::int16_t>(cx), static_cast<std::int16_t>(cy)}};
    seen[grid.index(cx, cy)] = 1;
    while (!queue.empty()) {
      const Cell c = queue.back();
      queue.pop_back();
      ++goal_area_cells;
      const int nx[4] = {c.x + 1, c.x - 1, c.x, c.x}, ny[4] = {c.y, c.y, c.y + 1, c.y - 1};
      for (int k = 0; k < 4; ++k) {
        if (!grid.contains(nx[k], ny[k])) continue;
        const int i = grid.index(nx[k], ny[k]);
        if (seen[i] || owners[i] != green) continue;
        seen[i] = 1;
        queue.push_back({static_cast<std::int16_t>(nx[k]), static_cast<std::int16_t>(ny[k])});
      }
    }
  }
  std::printf("green regions %d, the goal area's %d cells\n", green_regions, goal_area_cells);
  EXPECT_GE(goal_area_cells, params.tracker.classes[0].min_seed_cells);
  EXPECT_LE(goal_area_cells, 60);  // small: not merged with the field around it
}

// How many of `tested`'s line points have no point of `exact` within 5 px, and of how many
// (unmatched, total).
std::pair<long long, long long> unmatchedPoints(const LinePoints& tested, const LinePoints& exact) {
  long long unmatched = 0;
  for (const LinePoint& p : tested.points) {
    const bool near =
        std::any_of(exact.points.begin(), exact.points.end(),
                    [&](const LinePoint& q) { return std::hypot(p.u - q.u, p.v - q.v) <= 5.0; });
    unmatched += near ? 0 : 1;
  }
  return {unmatched, static_cast<long long>(tested.points.size())};
}

// The default vision classifies the cells on the mirror's outer rim every 2nd frame
// (tracker.mask_edge_every): on a rendered drive (1 m/s, turning at 90 and at 400 deg/s) its
// regions differ from the exact tracker's only near the rim, it classifies fewer cells, and its
// line points are the exact tracker's but for a few at the rim. The line points are compared with
// two samplings of the line detector: every 2nd contour corner without refinement (a scan's place
// depends on the contour only: at most 1 % of the points move) and the default, every 4th corner
// refined around line ends and turns (features9h): the refined scans are placed by their
// neighbours' results, so a point moved by a stale rim cell moves the scans around it too
// (measured 1.25 % / 2.1 % at 90 / 400 deg/s with the refinement's reach of 2 intervals; 2.4 % /
// 3.0 % with today's 1, where as many points move among fewer: at most 4 %).
TEST_F(RenderedFrames, TheRimCadenceDiffersFromTheExactTrackerOnlyNearTheRim) {
  for (const double omegaDeg : {90.0, 400.0}) {
    const VisionParams cadence = defaultVisionParams();
    ASSERT_EQ(cadence.tracker.mask_edge_every, 2);
    ASSERT_EQ(cadence.lines.sample_spacing, 4);
    ASSERT_GT(cadence.lines.refine_range_m, 0.0);
    VisionParams exactParams = cadence;
    exactParams.tracker.mask_edge_every = 1;
    VisionParams uniformCadence = cadence;
    uniformCadence.lines.sample_spacing = 2;
    uniformCadence.lines.refine_range_m = 0.0;
    VisionParams uniformExact = uniformCadence;
    uniformExact.tracker.mask_edge_every = 1;
    FrameProcessor tested(sim_->mirror, sim_->table, cadence);
    FrameProcessor exact(sim_->mirror, sim_->table, exactParams);
    FrameProcessor testedUniform(sim_->mirror, sim_->table, uniformCadence);
    FrameProcessor exactUniform(sim_->mirror, sim_->table, uniformExact);
    const CellGrid& grid = exact.grid();
    // Cells from the outer rim, in 4-connected steps.
    const std::vector<int> rimSteps = stepsFromOuterRim(grid, maskEdges(grid, exact.dontTouch()));
    const std::vector<geometry::Pose2> poses =
        motionPoses(sim_->field, {1.0, omegaDeg * M_PI / 180, 30.0}, 60);
    camera::SimScene scene;
    VisionResult testedResult, exactResult, uniformResult, uniformExactResult;
    long long testedCells = 0, exactCells = 0, points = 0, unmatched = 0, uniformPoints = 0,
              uniformUnmatched = 0;
    int differingFrames = 0, deepest = 0;
    for (int i = 0; i < 60; ++i) {
      scene.robot = poses[i];
      scene.frame_number = static_cast<std::uint64_t>(i);
      const camera::FrameView frame = sim_->render(scene);
      tested.process(frame, true, testedResult);
      exact.process(frame, true, exactResult);
      testedUniform.process(frame, true, uniformResult);
      exactUniform.process(frame, true, uniformExactResult);
      testedCells += testedResult.tracking.cells_classified;
      exactCells += exactResult.tracking.cells_classified;
      bool differs = false;
      for (int c = 0; c < grid.cellCount(); ++c) {
        const int x = c % grid.width, y = c / grid.width;
        if (tested.tracker().ownerOf(x, y) == exact.tracker().ownerOf(x, y)) continue;
        differs = true;
        deepest = std::max(deepest, rimSteps[c]);
      }
      differingFrames += differs ? 1 : 0;
      const auto [u, n] = unmatchedPoints(testedResult.lines, exactResult.lines);
      unmatched += u;
      points += n;
      const auto [uu, un] = unmatchedPoints(uniformResult.lines, uniformExactResult.lines);
      uniformUnmatched += uu;
      uniformPoints += un;
    }
    SCOPED_TRACE(omegaDeg);
    EXPECT_GT(differingFrames, 0);  // the cadence is not a no-op
    // Differences stay near the rim: 12 cells = 48 px (5 before bias10i's renderer change; since
    // then far lines are continuous, and at 400 deg/s two frames differ 9-12 cells in, in a
    // patch of 20 cells along a region that reaches the rim).
    EXPECT_LE(deepest, 12);
    EXPECT_LT(testedCells, exactCells * 0.97);
    ASSERT_GT(uniformPoints, 1000);
    ASSERT_GT(points, 1000);
    EXPECT_LT(static_cast<double>(uniformUnmatched), 0.01 * static_cast<double>(uniformPoints));
    EXPECT_LT(static_cast<double>(unmatched), 0.04 * static_cast<double>(points));
    std::printf(
        "%.0f deg/s: %d of 60 frames differ, at most %d cells from the rim; cells %lld "
        "vs %lld; line points not within 5 px of an exact one: %lld of %lld (every 2nd corner), "
        "%lld of %lld (default, refined)\n",
        omegaDeg, differingFrames, deepest, testedCells, exactCells, uniformUnmatched,
        uniformPoints, unmatched, points);
  }
}

TEST(MotionPoses, MoveAtTheGivenSpeedsAndStayInsideTheField) {
  for (const std::string preset : {"msl", "fu2004"}) {
    const field::FieldModel field = field::loadFieldPreset(preset);
    const Motion motion{2.0, 1.5, 30.0};
    const std::vector<geometry::Pose2> poses = motionPoses(field, motion, 600);
    ASSERT_EQ(poses.size(), 600u);
    for (std::size_t i = 1; i < poses.size(); ++i) {
      const double step = std::hypot(poses[i].x - poses[i - 1].x, poses[i].y - poses[i - 1].y);
      EXPECT_LE(step, 2.0 / 30.0 + 1e-9) << preset << " " << i;
      EXPECT_GE(step, 0.9 * 2.0 / 30.0) << preset << " " << i;  // chords of corner arcs
      EXPECT_NEAR(std::remainder(poses[i].phi - poses[i - 1].phi - 1.5 / 30.0, 2 * M_PI), 0.0,
                  1e-9);
      EXPECT_LT(std::abs(poses[i].x), field.length() / 2) << preset;
      EXPECT_LT(std::abs(poses[i].y), field.width() / 2) << preset;
    }
  }
}

TEST(VisionParams, TheShippedYamlHoldsTheDefaults) {
  const VisionParams loaded = loadVisionParams(config::Node::loadFile(
      config::projectRoot() + "/services/region_tracking/vision_default.yaml"));
  const VisionParams defaults = defaultVisionParams();
  EXPECT_EQ(loaded.tracker.cell_size, defaults.tracker.cell_size);
  EXPECT_EQ(loaded.tracker.reinitialise_period_frames, defaults.tracker.reinitialise_period_frames);
  EXPECT_EQ(loaded.tracker.mask_edge_every, defaults.tracker.mask_edge_every);
  EXPECT_EQ(loaded.tracker.mask_edge_inner, defaults.tracker.mask_edge_inner);
  ASSERT_EQ(loaded.tracker.classes.size(), defaults.tracker.classes.size());
  for (std::size_t i = 0; i < loaded.tracker.classes.size(); ++i) {
    const ClassTracking& a = loaded.tracker.classes[i];
    const ClassTracking& b = defaults.tracker.classes[i];
    EXPECT_EQ(a.class_id, b.class_id);
    EXPECT_EQ(a.search_when_lost, b.search_when_lost);
    EXPECT_EQ(a.max_seed_regions, b.max_seed_regions);
    EXPECT_EQ(a.min_seed_cells, b.min_seed_cells);
    EXPECT_EQ(a.seed_from_boundary_of, b.seed_from_boundary_of);
    EXPECT_EQ(a.view_edge_stride, b.view_edge_stride);
    EXPECT_EQ(a.search_inside_parent_stride, b.search_inside_parent_stride);
  }
  ASSERT_EQ(loaded.blocks.claims.size(), defaults.blocks.claims.size());
  for (std::size_t i = 0; i < loaded.blocks.claims.size(); ++i) {
    EXPECT_EQ(loaded.blocks.claims[i].colour, defaults.blocks.claims[i].colour);
    EXPECT_DOUBLE_EQ(loaded.blocks.claims[i].min_fraction, defaults.blocks.claims[i].min_fraction);
  }
  EXPECT_DOUBLE_EQ(loaded.lines.line_width, defaults.lines.line_width);
  EXPECT_DOUBLE_EQ(loaded.lines.width_tolerance, defaults.lines.width_tolerance);
  EXPECT_EQ(loaded.lines.max_transition_pixels, defaults.lines.max_transition_pixels);
  EXPECT_EQ(loaded.lines.max_gap_pixels, defaults.lines.max_gap_pixels);
  EXPECT_EQ(loaded.lines.field_confirm_pixels, defaults.lines.field_confirm_pixels);
  EXPECT_EQ(loaded.lines.end_at_self, defaults.lines.end_at_self);
  EXPECT_EQ(loaded.lines.ridge_contrast, defaults.lines.ridge_contrast);
  EXPECT_EQ(loaded.lines.ridge_min_levels, defaults.lines.ridge_min_levels);
  EXPECT_EQ(loaded.lines.sample_spacing, defaults.lines.sample_spacing);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_range_m, defaults.lines.refine_range_m);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_min_range_m, defaults.lines.refine_min_range_m);
  EXPECT_EQ(loaded.lines.refine_samples, defaults.lines.refine_samples);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_spacing_m, defaults.lines.refine_spacing_m);
  EXPECT_EQ(loaded.lines.refine_reach, defaults.lines.refine_reach);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_turn, defaults.lines.refine_turn);
  EXPECT_EQ(loaded.lines.refine_isolated, defaults.lines.refine_isolated);
  EXPECT_EQ(loaded.lines.smoothing_passes, defaults.lines.smoothing_passes);
  EXPECT_EQ(loaded.lines.tangent_half_span, defaults.lines.tangent_half_span);
  EXPECT_EQ(loaded.lines.min_contour_points, defaults.lines.min_contour_points);
  EXPECT_EQ(loaded.lines.max_gap_samples, defaults.lines.max_gap_samples);
  EXPECT_DOUBLE_EQ(loaded.ball.centre_height, defaults.ball.centre_height);
  EXPECT_EQ(loaded.ball.min_pixels, defaults.ball.min_pixels);
  EXPECT_DOUBLE_EQ(loaded.ball.size_tolerance, defaults.ball.size_tolerance);
  EXPECT_DOUBLE_EQ(loaded.ball.size_slack_px, defaults.ball.size_slack_px);
  EXPECT_DOUBLE_EQ(loaded.ball.min_fill, defaults.ball.min_fill);
  EXPECT_DOUBLE_EQ(loaded.ball.min_carpet_share, defaults.ball.min_carpet_share);
  EXPECT_EQ(loaded.obstacles.min_cells, defaults.obstacles.min_cells);
}

TEST(VisionParams, RejectsUnknownKeysAndColours) {
  const std::string good = R"(
tracker: {cell_size: 4, reinitialise_period_frames: 0, classes: [{class: green}]}
blocks: {claims: [{class: white, min_fraction: 0.2}]}
lines: {line_width: 0.05, width_tolerance: 2, max_transition_pixels: 1, sample_spacing: 1,
        smoothing_passes: 2, tangent_half_span: 2, min_contour_points: 8, max_gap_samples: 0}
ball: {centre_height: 0.11, min_pixels: 3}
obstacles: {min_cells: 2}
)";
  EXPECT_EQ(loadVisionParams(config::Node::loadString(good)).lines.line_width, 0.05);
  auto broken = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    text.replace(text.find(from), from.size(), to);
    return config::Node::loadString(text);
  };
  EXPECT_THROW(loadVisionParams(broken("class: white", "class: pink")), config::Error);
  EXPECT_THROW(loadVisionParams(broken("min_cells: 2", "min_cells: 2, colour: black")),
               config::Error);
  EXPECT_THROW(loadVisionParams(broken("line_width: 0.05", "line_width: -1")), config::Error);
  // The ridge rule: 0 turns it off; a contrast below 1 (darker than the carpet) is refused.
  EXPECT_EQ(loadVisionParams(broken("max_gap_samples: 0", "max_gap_samples: 0, ridge_contrast: 0"))
                .lines.ridge_contrast,
            0.0);
  EXPECT_THROW(
      loadVisionParams(broken("max_gap_samples: 0", "max_gap_samples: 0, ridge_contrast: 0.5")),
      config::Error);
  EXPECT_THROW(
      loadVisionParams(broken("max_gap_samples: 0", "max_gap_samples: 0, ridge_min_levels: -2")),
      config::Error);
}

TEST_F(RenderedFrames, RejectsFramesOfTheWrongSize) {
  FrameProcessor processor(sim_->mirror, sim_->table, defaultVisionParams());
  std::vector<std::uint8_t> data(64 * 2 * 48, 0);
  VisionResult result;
  EXPECT_THROW(
      processor.process({data.data(), 64, 48, 128, camera::PixelFormat::kYuyv}, true, result),
      std::invalid_argument);
  EXPECT_THROW(
      processor.process({nullptr, 320, 240, 640, camera::PixelFormat::kYuyv}, true, result),
      std::invalid_argument);
}

}  // namespace
}  // namespace fieldline::region_tracking

namespace fieldline::region_tracking {
namespace {

// Today's cameras (issue 32): the same detectors at 1280x960 (omni_sim_1280) with the default
// parameters, line points on the model's lines and the ball where it lies.
TEST(RenderedFrames1280, LinePointsAndBallAtTodaysResolution) {
  SimCamera sim = SimCamera::load("omni_sim_1280", "msl");
  ASSERT_EQ(sim.mirror.width(), 1280);
  ASSERT_EQ(sim.mirror.height(), 960);
  const geometry::Pose2 pose{1.0, 0.5, 0.3};
  const std::vector<Vec2> balls = {{0.6, 0.2}, {-1.5, 1.0}, {0.5, 3.0}, {3.2, -1.5}};
  for (const Vec2& ballInRobot : balls) {
    FrameProcessor processor(sim.mirror, sim.table, defaultVisionParams());
    camera::SimScene scene;
    scene.robot = pose;
    scene.ball = camera::SimBall{geometry::pointRobotToField(pose, ballInRobot), 0.11};
    const VisionResult result = sim.track(processor, scene, 3);
    ASSERT_TRUE(result.ball.visible) << ballInRobot.transpose();
    EXPECT_LE((Vec2(result.ball.x, result.ball.y) - ballInRobot).norm(), 0.05)
        << ballInRobot.transpose();
    std::vector<double> errors;
    for (const LinePoint& q : result.lines.points) {
      if (Vec2(q.x, q.y).norm() > 3.0) continue;
      errors.push_back(sim.field.distance(geometry::pointRobotToField(pose, Vec2(q.x, q.y))));
    }
    ASSERT_GE(errors.size(), 40u);
    EXPECT_LE(median(errors), 0.02);
  }
}

}  // namespace
}  // namespace fieldline::region_tracking
