#include "teamcomm/field_obstacles.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace fieldline::teamcomm {
namespace field_obstacles_test {

constexpr std::int64_t kT = 1'800'000'000'000'000;

perception::RobotEstimate pose(double x, double y, double phi) {
  perception::RobotEstimate e;
  e.utime = kT;
  e.pose = {x, y, phi};
  e.status = perception::LocalizationStatus::kTracking;
  return e;
}

perception::ObstacleSighting sighting(double x, double y, double width) {
  perception::ObstacleSighting s;
  s.x = x;
  s.y = y;
  s.width = width;
  s.distance = std::hypot(x, y);
  return s;
}

TEST(FieldObstacles, CentreOnTheFieldBehindTheNearestPoint) {
  // Robot at (1, 2) facing +y: an obstacle 1.5 m ahead (robot x) with width 0.5 has its centre
  // 1.75 m ahead, at field (1, 3.75); one 2 m to the left (robot y) lies at field (-1.25, 2).
  perception::ObstacleSightings seen;
  seen.utime = kT;
  seen.obstacles = {sighting(0.0, 2.0, 0.5), sighting(1.5, 0.0, 0.5)};
  const auto out = obstaclesInField(seen, pose(1.0, 2.0, std::numbers::pi / 2));
  ASSERT_EQ(out.size(), 2u);
  // Nearest first.
  EXPECT_NEAR(out[0].x, 1.0, 1e-5);
  EXPECT_NEAR(out[0].y, 3.75, 1e-5);
  EXPECT_NEAR(out[0].radius, 0.25, 1e-6);
  EXPECT_NEAR(out[1].x, -1.25, 1e-5);
  EXPECT_NEAR(out[1].y, 2.0, 1e-5);
}

TEST(FieldObstacles, PoseMovedToTheFramesTime) {
  perception::RobotEstimate p = pose(0.0, 0.0, 0.0);
  p.vx = 2.0;  // m/s along x
  perception::ObstacleSightings seen;
  seen.utime = kT + 100'000;  // the frame is 0.1 s newer: the robot was 0.2 m further
  seen.obstacles = {sighting(1.0, 0.0, 0.4)};
  const auto out = obstaclesInField(seen, p);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].x, 0.2 + 1.0 + 0.2, 1e-5);
}

TEST(FieldObstacles, AtMostTenInRangeAndOnlyWithAPose) {
  perception::ObstacleSightings seen;
  seen.utime = kT;
  for (int i = 0; i < 14; ++i)
    seen.obstacles.push_back(sighting(1.0 + i, 0.5, i == 3 ? 9.0 : 0.3));
  seen.obstacles.push_back(sighting(std::nan(""), 0.0, 0.3));
  seen.obstacles.push_back(sighting(40.0, 0.0, 0.3));  // off any field: clamped to the range
  auto out = obstaclesInField(seen, pose(0, 0, 0));
  ASSERT_EQ(out.size(), static_cast<std::size_t>(kMaxObstacles));
  for (const PacketObstacle& o : out) {
    EXPECT_LE(std::fabs(o.x), kMaxFieldCoordinate_m);
    EXPECT_GE(o.radius, 0.05f);
    EXPECT_LE(o.radius, kMaxObstacleRadius_m);
  }
  EXPECT_FLOAT_EQ(out[3].radius, static_cast<float>(kMaxObstacleRadius_m));
  // The packet takes them as they are.
  TeamKey key{};
  TeamPacket packet;
  packet.robot_id = 1;
  packet.send_utime = kT;
  packet.obstacles = out;
  const auto decoded = decodePacket(encodePacket(packet, key), key);
  ASSERT_TRUE(decoded.packet.has_value());
  ASSERT_EQ(decoded.packet->obstacles.size(), out.size());
  EXPECT_EQ(decoded.packet->obstacles[9].x, out[9].x);

  perception::RobotEstimate lost = pose(0, 0, 0);
  lost.status = perception::LocalizationStatus::kSearching;
  EXPECT_TRUE(obstaclesInField(seen, lost).empty());
  perception::RobotEstimate old = pose(0, 0, 0);
  old.utime = kT - 500'000;
  EXPECT_TRUE(obstaclesInField(seen, old).empty());
}

}  // namespace field_obstacles_test
}  // namespace fieldline::teamcomm
