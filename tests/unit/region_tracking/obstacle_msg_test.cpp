// obstacle_observations_t <-> perception::ObstacleSightings (common/msg/obstacle_observations.hpp):
// a round trip keeps every field (to float precision), and an empty list clears the arrays.
#include "common/msg/obstacle_observations.hpp"

#include <gtest/gtest.h>

#include "common/bus/validate.hpp"

namespace fieldline::msg {
namespace obstacle_msg_test {

TEST(ObstacleMsg, RoundTripKeepsEveryFieldAndTheMessageValidates) {
  perception::ObstacleSightings s;
  s.utime = 1'800'000'000'000'000;
  s.obstacles.push_back({0.5, 2.0, 0.2, 0.4, 1.7, 0.9});
  s.obstacles.push_back({-2.5, 1.0, 0.5, 0.5, -0.8, -0.6});
  obstacle_observations_t m{};
  toMessage(s, m);
  EXPECT_EQ(m.header.utime, s.utime);
  EXPECT_EQ(m.count, 2);
  EXPECT_FALSE(bus::validate(m)) << *bus::validate(m);

  const perception::ObstacleSightings back = toObstacleSightings(m);
  EXPECT_EQ(back.utime, s.utime);
  ASSERT_EQ(back.obstacles.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& a = s.obstacles[i];
    const auto& b = back.obstacles[i];
    EXPECT_FLOAT_EQ(b.bearing, a.bearing);
    EXPECT_FLOAT_EQ(b.distance, a.distance);
    EXPECT_FLOAT_EQ(b.angular_width, a.angular_width);
    EXPECT_FLOAT_EQ(b.width, a.width);
    EXPECT_FLOAT_EQ(b.x, a.x);
    EXPECT_FLOAT_EQ(b.y, a.y);
  }

  // A frame without obstacles leaves no element of the previous one behind.
  s.obstacles.clear();
  toMessage(s, m);
  EXPECT_EQ(m.count, 0);
  EXPECT_TRUE(m.bearing.empty());
  EXPECT_TRUE(m.y.empty());
  EXPECT_FALSE(bus::validate(m));
}

}  // namespace obstacle_msg_test
}  // namespace fieldline::msg
