// The line detector's sampling by distance on the field (lines.sample_spacing_m) against the
// sampling by contour index, and the refinement around line ends and turns, on frames rendered by
// the simulated camera (msl field, omni_sim camera 320x240, 4x4 cells).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "common/config/config.hpp"
#include "common/geometry/geometry.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::region_tracking {
namespace {

using camera::Vec2;

class LineSampling : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { sim_ = new SimCamera(SimCamera::load("omni_sim", "msl")); }
  static void TearDownTestSuite() {
    delete sim_;
    sim_ = nullptr;
  }
  static VisionParams params(double spacingMetres) {
    VisionParams p = defaultVisionParams();
    p.lines.sample_spacing_m = spacingMetres;
    return p;
  }
  VisionResult track(const VisionParams& p, const geometry::Pose2& pose) {
    FrameProcessor processor(sim_->mirror, sim_->table, p);
    camera::SimScene scene;
    scene.robot = pose;
    return sim_->track(processor, scene, 3);
  }
  static SimCamera* sim_;
};
SimCamera* LineSampling::sim_ = nullptr;

double median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// Floor distance between consecutive points of every sequence whose midpoint is [near, far) m
// from the robot.
std::vector<double> neighbourSpacings(const LinePoints& lines, double near, double far) {
  std::vector<double> spacings;
  for (const auto& [first, end] : lines.sequences) {
    for (int i = first; i + 1 < end; ++i) {
      const LinePoint& a = lines.points[i];
      const LinePoint& b = lines.points[i + 1];
      const double range = std::hypot(0.5 * (a.x + b.x), 0.5 * (a.y + b.y));
      if (range >= near && range < far) spacings.push_back(std::hypot(b.x - a.x, b.y - a.y));
    }
  }
  return spacings;
}

// The floor length the detector assigns to an image step is the floor lookup's distance between
// the step's ends (to a few per cent: the Jacobian is taken at the nearest cell corner).
TEST_F(LineSampling, FloorLengthOfAnImageStepMatchesTheFloorLookup) {
  const FrameProcessor processor(sim_->mirror, sim_->table, params(0.1));
  const FloorLookup& floor = processor.floor();
  const LineDetector detector(sim_->table, floor, params(0.1).lines, 4);
  int checked = 0;
  for (int v = 20; v < floor.height() - 20; v += 13) {
    for (int u = 20; u < floor.width() - 20; u += 11) {
      for (const auto& [du, dv] : {std::pair{3.0f, 0.0f}, {0.0f, 3.0f}, {2.0f, -2.0f}}) {
        float x0, y0, x1, y1;
        if (!floor.floorPoint(u - 0.5f * du, v - 0.5f * dv, x0, y0) ||
            !floor.floorPoint(u + 0.5f * du, v + 0.5f * dv, x1, y1)) {
          continue;
        }
        const double exact = std::hypot(x1 - x0, y1 - y0);
        if (std::hypot(x0, y0) > 5.0) continue;  // the mirror's rim: metres per pixel explode
        const float length =
            detector.floorLength(static_cast<float>(u), static_cast<float>(v), du, dv);
        EXPECT_NEAR(length, exact, 0.08 * exact + 0.002) << u << "," << v << " " << du << "," << dv;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 300);
  // Outside the image there is no floor: length 0, so no samples there.
  EXPECT_EQ(detector.floorLength(-50.0f, -50.0f, 3.0f, 0.0f), 0.0f);
}

// By distance, consecutive points lie about the asked spacing apart on the floor, near the robot
// and 2-4 m away alike; by index (every 2nd contour corner, no refinement: the default until
// features9h, whose every 4th corner plus refinement is uneven on purpose), the far points are
// much sparser than the near ones. The points keep their accuracy and coverage.
TEST_F(LineSampling, PointsAreSpacedEvenlyOnTheFloorAndStayOnTheLines) {
  const std::vector<geometry::Pose2> poses = {
      {1.0, 0.5, 0.3}, {-6.5, 0.5, 3.0}, {-8.0, -1.5, M_PI}, {5.5, -2.0, 0.4}};
  const double spacing = 0.1;
  VisionParams everySecond = params(0.0);
  everySecond.lines.sample_spacing = 2;
  everySecond.lines.refine_range_m = 0.0;
  std::vector<double> nearByIndex, farByIndex, nearByDistance, farByDistance, errors;
  const std::vector<Vec2> modelSamples = sim_->field.sampleLines(0.02);
  for (const geometry::Pose2& pose : poses) {
    const VisionResult byIndex = track(everySecond, pose);
    const VisionResult byDistance = track(params(spacing), pose);
    for (double s : neighbourSpacings(byIndex.lines, 0.5, 1.5))
      nearByIndex.push_back(s);
    for (double s : neighbourSpacings(byIndex.lines, 2.0, 4.0))
      farByIndex.push_back(s);
    for (double s : neighbourSpacings(byDistance.lines, 0.5, 1.5))
      nearByDistance.push_back(s);
    for (double s : neighbourSpacings(byDistance.lines, 2.0, 4.0))
      farByDistance.push_back(s);

    std::vector<Vec2> fieldPoints;
    for (const LinePoint& q : byDistance.lines.points) {
      fieldPoints.push_back(geometry::pointRobotToField(pose, Vec2(q.x, q.y)));
      if (Vec2(q.x, q.y).norm() <= 4.0) errors.push_back(sim_->field.distance(fieldPoints.back()));
    }
    // Coverage of the visible model lines within 4 m: a point within 10 cm.
    int visible = 0, covered = 0;
    for (const Vec2& sample : modelSamples) {
      const Vec2 inRobot = geometry::pointFieldToRobot(pose, sample);
      if (inRobot.norm() > 4.0) continue;
      const std::optional<Vec2> pixel = sim_->mirror.robotToImage(inRobot);
      if (!pixel || sim_->mirror.zone(*pixel) != camera::MirrorZone::kUseful) continue;
      ++visible;
      covered += std::any_of(fieldPoints.begin(), fieldPoints.end(),
                             [&](const Vec2& p) { return (p - sample).norm() <= 0.10; });
    }
    ASSERT_GT(visible, 100);
    EXPECT_GE(static_cast<double>(covered) / visible, 0.85) << pose.x << "," << pose.y;
  }
  ASSERT_GE(farByDistance.size(), 30u);
  ASSERT_GE(nearByDistance.size(), 30u);
  std::printf("median spacing near / 2-4 m: by index %.3f / %.3f m, by distance %.3f / %.3f m\n",
              median(nearByIndex), median(farByIndex), median(nearByDistance),
              median(farByDistance));
  EXPECT_NEAR(median(nearByDistance), spacing, 0.3 * spacing);
  EXPECT_NEAR(median(farByDistance), spacing, 0.3 * spacing);
  EXPECT_GT(median(farByIndex), 1.3 * spacing);
  EXPECT_LE(median(errors), 0.02);
}

// The refinement (lines.refine_range_m) spends its scans where lines end or turn within range:
// with every 4th corner plus the refinement the detector runs about as many scans as every 2nd
// corner alone, but finds far more points on the penalty areas' corners 2-4 m away (the
// recogniser's penalty corners need a few points on both lines there), fewer elsewhere, and the
// points stay on the lines.
TEST_F(LineSampling, RefinementPutsTheScansWhereTheLinesEndOrTurn) {
  VisionParams everySecond = defaultVisionParams();
  everySecond.lines.sample_spacing = 2;
  everySecond.lines.sample_spacing_m = 0.0;
  everySecond.lines.refine_range_m = 0.0;
  VisionParams refined = everySecond;
  refined.lines.sample_spacing = 4;
  refined.lines.refine_range_m = 4.5;
  refined.lines.refine_samples = 4;
  refined.lines.refine_spacing_m = 0.1;
  refined.lines.refine_reach = 2;
  const auto& d = sim_->field.dimensions();
  // The eight penalty-area and goal-area corners.
  std::vector<Vec2> corners;
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      corners.emplace_back(sx * (sim_->field.length() / 2 - d.penalty_area_depth),
                           sy * d.penalty_area_width / 2);
      corners.emplace_back(sx * (sim_->field.length() / 2 - d.goal_area_depth),
                           sy * d.goal_area_width / 2);
    }
  }
  // Robots 2.5-3.5 m from a corner, on the field side of it, with several headings.
  std::vector<geometry::Pose2> poses;
  int k = 0;
  for (const Vec2& c : corners) {
    if (c.x() < 0 || c.y() < 0) continue;  // one quarter: the others are its mirror images
    for (double a : {2.2, 2.8, 3.5, 4.1}) {
      const double r = 2.5 + 0.33 * (k % 4);
      const Vec2 p = c + r * Vec2(std::cos(a), std::sin(a));
      if (std::abs(p.y()) > d.width / 2 - 0.3) continue;
      poses.push_back({p.x(), p.y(), 0.9 * k++});
    }
  }
  ASSERT_GE(poses.size(), 6u);
  long scansSecond = 0, scansRefined = 0;
  int cornerSecond = 0, cornerRefined = 0, nearSecond = 0, nearRefined = 0;
  std::vector<double> errors;
  for (const geometry::Pose2& pose : poses) {
    for (int which = 0; which < 2; ++which) {
      FrameProcessor processor(sim_->mirror, sim_->table, which == 0 ? everySecond : refined);
      camera::SimScene scene;
      scene.robot = pose;
      const VisionResult result = sim_->track(processor, scene, 3);
      (which == 0 ? scansSecond : scansRefined) += processor.lineDetector().scans();
      for (const LinePoint& q : result.lines.points) {
        const Vec2 local(q.x, q.y);
        const Vec2 onField = geometry::pointRobotToField(pose, local);
        if (which == 1 && local.norm() <= 4.5) errors.push_back(sim_->field.distance(onField));
        if (local.norm() < 1.5) ++(which == 0 ? nearSecond : nearRefined);
        for (const Vec2& c : corners) {
          const double range = geometry::pointFieldToRobot(pose, c).norm();
          if (range >= 2.0 && range <= 4.0 && (onField - c).norm() <= 0.7) {
            ++(which == 0 ? cornerSecond : cornerRefined);
          }
        }
      }
    }
  }
  std::printf(
      "scans %ld / %ld, points near corners 2-4 m away %d / %d, within 1.5 m %d / %d "
      "(every 2nd corner / every 4th + refinement)\n",
      scansSecond, scansRefined, cornerSecond, cornerRefined, nearSecond, nearRefined);
  ASSERT_GT(cornerSecond, 20);
  EXPECT_LE(scansRefined, 1.15 * scansSecond);
  EXPECT_GE(cornerRefined, 1.4 * cornerSecond);
  EXPECT_LT(nearRefined, nearSecond);
  EXPECT_LE(median(errors), 0.02);
}

TEST_F(LineSampling, RefusesBadParameters) {
  const FrameProcessor processor(sim_->mirror, sim_->table, params(0.1));
  const FloorLookup& floor = processor.floor();
  LineDetectorParams bad = params(0.1).lines;
  bad.sample_spacing_m = -0.1;
  EXPECT_THROW(LineDetector(sim_->table, floor, bad, 4), std::invalid_argument);
  bad.sample_spacing_m = std::nan("");
  EXPECT_THROW(LineDetector(sim_->table, floor, bad, 4), std::invalid_argument);
  bad = params(0.1).lines;
  bad.sample_min_px = 0.0;
  EXPECT_THROW(LineDetector(sim_->table, floor, bad, 4), std::invalid_argument);
  bad = params(0.1).lines;
  bad.refine_range_m = -1.0;
  EXPECT_THROW(LineDetector(sim_->table, floor, bad, 4), std::invalid_argument);
  bad = params(0.1).lines;
  bad.refine_samples = 0;
  EXPECT_THROW(LineDetector(sim_->table, floor, bad, 4), std::invalid_argument);
  bad = params(0.1).lines;
  bad.refine_reach = 0;
  EXPECT_THROW(LineDetector(sim_->table, floor, bad, 4), std::invalid_argument);
  bad = params(0.1).lines;
  bad.refine_spacing_m = std::nan("");
  EXPECT_THROW(LineDetector(sim_->table, floor, bad, 4), std::invalid_argument);

  const std::string yaml = R"(
tracker: {cell_size: 4, reinitialise_period_frames: 0, classes: [{class: green}]}
blocks: {claims: [{class: white, min_fraction: 0.2}]}
lines: {line_width: 0.05, width_tolerance: 2, max_transition_pixels: 1, sample_spacing: 2,
        sample_spacing_m: 0.08, sample_min_px: 1.5, refine_range_m: 4, refine_samples: 5,
        refine_spacing_m: 0.12, refine_reach: 3, refine_turn: 0.6, refine_min_range_m: 0.5,
        smoothing_passes: 2, tangent_half_span: 2, min_contour_points: 8, max_gap_samples: 0}
ball: {centre_height: 0.11, min_pixels: 3}
obstacles: {min_cells: 2}
)";
  const VisionParams loaded = loadVisionParams(config::Node::loadString(yaml));
  EXPECT_DOUBLE_EQ(loaded.lines.sample_spacing_m, 0.08);
  EXPECT_DOUBLE_EQ(loaded.lines.sample_min_px, 1.5);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_range_m, 4.0);
  EXPECT_EQ(loaded.lines.refine_samples, 5);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_spacing_m, 0.12);
  EXPECT_EQ(loaded.lines.refine_reach, 3);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_turn, 0.6);
  EXPECT_DOUBLE_EQ(loaded.lines.refine_min_range_m, 0.5);
  std::string negative = yaml;
  negative.replace(negative.find("sample_spacing_m: 0.08"), 22, "sample_spacing_m: -1");
  EXPECT_THROW(loadVisionParams(config::Node::loadString(negative)), config::Error);
  std::string noSamples = yaml;
  noSamples.replace(noSamples.find("refine_samples: 5"), 17, "refine_samples: 0");
  EXPECT_THROW(loadVisionParams(config::Node::loadString(noSamples)), config::Error);
}

}  // namespace
}  // namespace fieldline::region_tracking
