#include "common/camera/mirror_model.hpp"

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "common/config/config.hpp"

namespace fieldline::camera {
namespace mirror_model_test {

constexpr double kPi = std::numbers::pi;

MirrorModel simMirror() {
  return loadCameraPreset("omni_sim").mirror;
}

TEST(DistanceFunction, LinearPartAndKneeByHand) {
  const DistanceFunction f(LinearExponentialParams{0.02, 60.0, 0.03});
  EXPECT_DOUBLE_EQ(f.floorDistance(0.0, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(f.floorDistance(30.0, 1.0), 0.6);
  EXPECT_DOUBLE_EQ(f.floorDistance(60.0, 0.0), 1.2);
  // 1.2 + (0.02 / 0.03) * (e^(0.03 * 60) - 1) = 1.2 + 0.6667 * 5.0496 = 4.5664
  EXPECT_NEAR(f.floorDistance(120.0, 0.0), 4.56640, 1e-4);
  // Same slope on both sides of the knee: smooth.
  EXPECT_NEAR(f.metresPerPixel(59.999, 0.0), f.metresPerPixel(60.001, 0.0), 1e-5);
  EXPECT_TRUE(std::isnan(f.floorDistance(-1.0, 0.0)));
  EXPECT_TRUE(std::isnan(f.imageRadius(std::nan(""), 0.0)));
}

TEST(DistanceFunction, MonotonicAndInverseRoundTrips) {
  const DistanceFunction f(LinearExponentialParams{0.02, 60.0, 0.03});
  double previous = -1.0;
  for (double r = 0.0; r <= 200.0; r += 0.25) {
    const double d = f.floorDistance(r, 0.3);
    EXPECT_GT(d, previous) << "r=" << r;
    previous = d;
    EXPECT_NEAR(f.imageRadius(d, 0.3), r, 1e-9) << "r=" << r;
  }
}

TEST(DistanceFunction, TableInterpolatesByHandAndRoundTrips) {
  CalibrationTableParams t;
  t.radii = {20.0, 60.0, 100.0};
  t.sector_bearings = {0.0, kPi / 2};
  t.distances = {{0.4, 1.2, 4.0}, {0.5, 1.4, 5.0}};
  const DistanceFunction f(t);
  // Below the first radius: linear to the origin.
  EXPECT_NEAR(f.floorDistance(10.0, 0.0), 0.2, 1e-12);
  EXPECT_NEAR(f.floorDistance(80.0, 0.0), 2.6, 1e-12);
  EXPECT_NEAR(f.floorDistance(80.0, kPi / 2), 3.2, 1e-12);
  // Halfway between the sectors: the average of 2.6 and 3.2.
  EXPECT_NEAR(f.floorDistance(80.0, kPi / 4), 2.9, 1e-12);
  // From pi/2 the next sector counter-clockwise is 0 again (at 2 pi): 3/4 of the way at 7pi/8.
  EXPECT_NEAR(f.floorDistance(80.0, kPi / 2 + 0.75 * 1.5 * kPi), 0.25 * 3.2 + 0.75 * 2.6, 1e-12);
  EXPECT_TRUE(std::isnan(f.floorDistance(100.5, 0.0)));
  EXPECT_TRUE(std::isnan(f.imageRadius(5.1, kPi / 2)));

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> radius(0.0, 100.0), bearing(-kPi, kPi);
  for (int k = 0; k < 1000; ++k) {
    const double r = radius(rng);
    const double b = bearing(rng);
    EXPECT_NEAR(f.imageRadius(f.floorDistance(r, b), b), r, 1e-9);
    EXPECT_GT(f.floorDistance(r + 0.1, b), f.floorDistance(r, b));
  }
}

TEST(DistanceFunction, RejectsBadTables) {
  CalibrationTableParams t;
  t.radii = {20.0, 10.0};
  t.sector_bearings = {0.0};
  t.distances = {{0.4, 1.2}};
  EXPECT_THROW(DistanceFunction{t}, std::invalid_argument);
  t.radii = {10.0, 20.0};
  t.distances = {{1.2, 0.4}};
  EXPECT_THROW(DistanceFunction{t}, std::invalid_argument);
  t.distances = {{0.4}};
  EXPECT_THROW(DistanceFunction{t}, std::invalid_argument);
  EXPECT_THROW(DistanceFunction(LinearExponentialParams{0.0, 60.0, 0.03}), std::invalid_argument);
}

TEST(MirrorModel, HeadingAppearsOnTheDiagonalAndLeftClockwise) {
  const MirrorModel m = simMirror();
  // One metre ahead: 50 px from the centre toward the top-right corner (direction (4, -3) / 5).
  const Vec2 ahead = *m.robotToImage(Vec2(1.0, 0.0));
  EXPECT_NEAR(ahead.x(), 159.5 + 40.0, 0.01);
  EXPECT_NEAR(ahead.y(), 119.5 - 30.0, 0.01);
  // One metre to the left: mirrored, so 90 degrees clockwise on screen: direction (3, 4) / 5.
  const Vec2 left = *m.robotToImage(Vec2(0.0, 1.0));
  EXPECT_NEAR(left.x(), 159.5 + 30.0, 0.01);
  EXPECT_NEAR(left.y(), 119.5 + 40.0, 0.01);
  EXPECT_NEAR(m.bearingOf(left), kPi / 2, 1e-9);
}

TEST(MirrorModel, FloorPointRoundTripWithinOneMillimetre) {
  for (const char* preset : {"omni_sim", "omni_sim_640"}) {
    const MirrorModel m = loadCameraPreset(preset).mirror;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, m.width() - 1.0), v(0.0, m.height() - 1.0);
    int checked = 0;
    for (int k = 0; k < 20000; ++k) {
      const Vec2 px(u(rng), v(rng));
      if (m.zone(px) != MirrorZone::kUseful) continue;
      const Vec2 floor = *m.imageToRobot(px);
      const std::optional<Vec2> back = m.robotToImage(floor);
      ASSERT_TRUE(back.has_value());
      EXPECT_LT((*back - px).norm(), 1e-6);
      // And floor -> image -> floor.
      const Vec2 again = *m.imageToRobot(*back);
      EXPECT_LT((again - floor).norm(), 1e-3) << preset << " " << px.transpose();
      ++checked;
    }
    EXPECT_GT(checked, 5000);
  }
}

TEST(MirrorModel, TableMirrorOffCentreRoundTrips) {
  MirrorParams p;
  p.centre = Vec2(163.0, 116.0);
  CalibrationTableParams t;
  t.radii = {15.0, 40.0, 80.0, 120.0, 140.0, 160.0};
  t.sector_bearings = {-2.0, 0.0, 2.0};
  t.distances = {{0.3, 0.8, 2.0, 4.5, 7.0, 11.0},
                 {0.32, 0.85, 2.1, 4.8, 7.5, 12.0},
                 {0.29, 0.78, 1.9, 4.3, 6.6, 10.0}};
  p.distance = DistanceFunction(t);
  const MirrorModel m(p);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(-6.0, 6.0);
  int checked = 0;
  for (int k = 0; k < 5000; ++k) {
    const Vec2 floor(x(rng), x(rng));
    const std::optional<Vec2> px = m.robotToImage(floor);
    if (!px || m.zone(*px) != MirrorZone::kUseful) continue;
    EXPECT_LT((*m.imageToRobot(*px) - floor).norm(), 1e-3);
    ++checked;
  }
  EXPECT_GT(checked, 1000);
}

TEST(MirrorModel, ThreeDimensionalPointsFollowTheReferenceRay) {
  const MirrorModel m = simMirror();
  const double H = m.params().reference_height;  // 0.6 m
  // The ball's centre 2 m ahead at 0.11 m is imaged where the floor 2 * 0.6 / 0.49 m ahead is.
  const Vec2 ball = *m.robotPointToImage(Vec3(2.0, 0.0, 0.11));
  const Vec2 floor = *m.robotToImage(Vec2(2.0 * H / (H - 0.11), 0.0));
  EXPECT_LT((ball - floor).norm(), 1e-9);
  const Vec3 back = *m.imageToRobotAtHeight(ball, 0.11);
  EXPECT_NEAR(back.x(), 2.0, 1e-9);
  EXPECT_NEAR(back.y(), 0.0, 1e-9);
  EXPECT_NEAR(back.z(), 0.11, 1e-12);
  EXPECT_FALSE(m.robotPointToImage(Vec3(2.0, 0.0, H)).has_value());
  EXPECT_FALSE(m.imageToRobotAtHeight(ball, 0.7).has_value());
}

TEST(MirrorModel, ZonesAndDontTouchMask) {
  const MirrorModel m = simMirror();
  EXPECT_EQ(m.zone(Vec2(159.5, 119.5)), MirrorZone::kSelf);
  EXPECT_EQ(m.zone(Vec2(159.5 + 20.0, 119.5)), MirrorZone::kUseful);
  EXPECT_EQ(m.zone(Vec2(159.5 + 140.0, 119.5)), MirrorZone::kFar);
  EXPECT_EQ(m.zone(Vec2(2.0, 2.0)), MirrorZone::kOutside);
  EXPECT_EQ(m.zone(Vec2(-3.0, 119.0)), MirrorZone::kOutside);
  EXPECT_FALSE(m.imageToRobot(Vec2(159.5, 119.5)).has_value());
  EXPECT_FALSE(m.imageToRobot(Vec2(2.0, 2.0)).has_value());
  const std::vector<std::uint8_t> mask = m.dontTouchMask();
  ASSERT_EQ(mask.size(), 320u * 240u);
  EXPECT_EQ(mask[120 * 320 + 160], 1);       // self reflection
  EXPECT_EQ(mask[120 * 320 + 160 + 30], 0);  // floor
  EXPECT_EQ(mask[0], 1);                     // corner, outside the mirror
}

TEST(MirrorModel, ContourUndistortionSkipsInvalidPixels) {
  const MirrorModel m = simMirror();
  const std::vector<Vec2> contour = {Vec2(200.0, 100.0), Vec2(159.5, 119.5), Vec2(210.0, 100.0),
                                     Vec2(std::nan(""), 3.0)};
  std::vector<Vec2> out;
  EXPECT_EQ(m.imageToRobot(contour, out), 2u);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_LT((out[0] - *m.imageToRobot(contour[0])).norm(), 1e-12);
}

TEST(MirrorModel, ScaledPresetMatchesThe640Preset) {
  const MirrorModel scaled = simMirror().scaledTo(640, 480);
  const MirrorModel big = loadCameraPreset("omni_sim_640").mirror;
  for (const Vec2& floor : {Vec2(1.0, 0.5), Vec2(-3.0, 2.0), Vec2(0.4, -4.0)}) {
    EXPECT_LT((*scaled.robotToImage(floor) - *big.robotToImage(floor)).norm(), 1e-9);
  }
  EXPECT_THROW((void)simMirror().scaledTo(640, 360), std::invalid_argument);
}

TEST(MirrorModel, PresetErrorsNameFileAndKey) {
  const std::string yaml =
      "image: {width: 320, height: 240}\n"
      "colour_table: colours_sim\n"
      "mirror:\n"
      "  centre: [159.5, 119.5]\n"
      "  heading_angle: 0.0\n"
      "  mirrored: true\n"
      "  outer_radius: 150.0\n"
      "  useful_radius: 160.0\n"
      "  self_radius: 14.0\n"
      "  reference_height: 0.6\n"
      "  distance_function: {type: linear_exponential, slope: 0.02, knee_radius: 60, growth: "
      "0.03}\n";
  try {
    (void)loadCameraModel(config::Node::loadString(yaml, "bad.yaml"));
    FAIL() << "expected a config error";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("self < useful <= outer"), std::string::npos) << e.what();
  }
}

// The mirror axis 6 cm ahead and 4 cm right of the robot's centre: every robot-frame mapping
// moves by that offset, image radius and bearing stay about the axis.
TEST(MirrorModel, AxisOffsetMovesEveryRobotFrameMapping) {
  MirrorParams p = simMirror().params();
  const MirrorModel centred(p);
  p.axis_offset = Vec2(0.06, -0.04);
  const MirrorModel m(p);
  for (const Vec2& px : {Vec2(200.0, 100.0), Vec2(120.0, 150.0), Vec2(250.0, 60.0)}) {
    const Vec2 robot = *m.imageToRobot(px);
    EXPECT_LT((robot - (*centred.imageToRobot(px) + p.axis_offset)).norm(), 1e-12);
    EXPECT_LT((*m.imageToAxis(px) - *centred.imageToRobot(px)).norm(), 1e-12);
    EXPECT_LT((*m.robotToImage(robot) - px).norm(), 1e-9);
  }
  // A floor point 0.30 m ahead of the axis is where the centred mirror sees 0.30 m ahead.
  const Vec2 centrePx = *m.robotToImage(Vec2(0.30, 0.0) + p.axis_offset);
  EXPECT_LT((centrePx - *centred.robotToImage(Vec2(0.30, 0.0))).norm(), 1e-9);
  // 3-D points project about the axis: the ball 2 m ahead of the axis at 0.11 m is imaged where
  // the floor 2 * H / (H - 0.11) m ahead of the axis is.
  const double H = p.reference_height;
  const Vec2 ball = *m.robotPointToImage(Vec3(2.06, -0.04, 0.11));
  EXPECT_LT((ball - *centred.robotToImage(Vec2(2.0 * H / (H - 0.11), 0.0))).norm(), 1e-9);
  const Vec3 back = *m.imageToRobotAtHeight(ball, 0.11);
  EXPECT_NEAR(back.x(), 2.06, 1e-9);
  EXPECT_NEAR(back.y(), -0.04, 1e-9);
  // Scaling keeps the offset (metres).
  EXPECT_EQ(m.scaledTo(640, 480).params().axis_offset, p.axis_offset);
  p.axis_offset = Vec2(2.0, 0.0);
  EXPECT_THROW(MirrorModel{p}, std::invalid_argument);
}

TEST(MirrorModel, AxisOffsetIsReadFromThePresetAndOptional) {
  const std::string yaml =
      "image: {width: 320, height: 240}\n"
      "colour_table: colours_sim\n"
      "mirror:\n"
      "  centre: [159.5, 119.5]\n"
      "  heading_angle: 0.0\n"
      "  mirrored: true\n"
      "  outer_radius: 150.0\n"
      "  useful_radius: 135.0\n"
      "  self_radius: 14.0\n"
      "  reference_height: 0.6\n"
      "  axis_offset: [0.05, 0.03]\n"
      "  distance_function: {type: linear_exponential, slope: 0.02, knee_radius: 60, growth: "
      "0.03}\n";
  const CameraModel model = loadCameraModel(config::Node::loadString(yaml, "offset.yaml"));
  EXPECT_EQ(model.mirror.params().axis_offset, Vec2(0.05, 0.03));
  EXPECT_EQ(simMirror().params().axis_offset, Vec2::Zero());
  std::string far = yaml;
  far.replace(far.find("[0.05, 0.03]"), 12, "[1.50, 0.00]");
  try {
    (void)loadCameraModel(config::Node::loadString(far, "far.yaml"));
    FAIL() << "expected a config error";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("axis_offset"), std::string::npos) << e.what();
  }
}

}  // namespace mirror_model_test
}  // namespace fieldline::camera
