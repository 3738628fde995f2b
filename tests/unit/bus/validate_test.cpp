#include <algorithm>
#include <limits>

#include <gtest/gtest.h>

#include "common/bus/validate.hpp"

namespace fieldline::bus {
namespace validate_test {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

image_t goodImage() {
  image_t m{};
  m.header.utime = 1;
  m.width = 4;
  m.height = 2;
  m.stride = 8;
  m.format = image_t::FORMAT_YUYV;
  m.size = 16;
  m.data.resize(16);
  return m;
}

TEST(Validate, OdometryWheelCountAndSizes) {
  odometry_t m{};
  m.header.utime = 1;
  m.wheel_count = 4;
  m.ticks = {1, 2, 3, 4};
  m.wheel_current = {0, 0, 0, 0};
  EXPECT_FALSE(validate(m));
  m.wheel_count = 3;
  EXPECT_TRUE(validate(m));  // arrays of four
  m.ticks.resize(3);
  m.wheel_current.resize(3);
  EXPECT_FALSE(validate(m));
  // No ticks (a controller that reports its movement), but then no currents either.
  m.wheel_count = 0;
  m.ticks.clear();
  m.wheel_current.clear();
  EXPECT_FALSE(validate(m));
  m.status = odometry_t::STATUS_CURRENTS;
  EXPECT_TRUE(validate(m));
  m.status = 0;
  for (const int bad : {-1, 1, 2, 5, 100}) {
    m.wheel_count = bad;
    m.ticks.assign(static_cast<std::size_t>(std::max(bad, 0)), 0);
    m.wheel_current.assign(static_cast<std::size_t>(std::max(bad, 0)), 0.0f);
    const auto problem = validate(m);
    ASSERT_TRUE(problem) << bad;
    EXPECT_NE(problem->find("wheel_count"), std::string::npos) << *problem;
  }
  m.wheel_count = 3;
  m.ticks.assign(3, 0);
  m.wheel_current.assign(3, 0.0f);
  m.dx = kNan;
  EXPECT_TRUE(validate(m));
}

TEST(Validate, ImageSizes) {
  image_t m = goodImage();
  EXPECT_FALSE(validate(m));
  m.size = 15;
  EXPECT_TRUE(validate(m));
  m = goodImage();
  m.stride = 7;
  EXPECT_TRUE(validate(m));
  m = goodImage();
  m.format = 9;
  EXPECT_TRUE(validate(m));
  m = goodImage();
  m.width = 3;
  m.stride = 6;
  m.size = 12;
  EXPECT_TRUE(validate(m));  // YUYV needs an even width
}

TEST(Validate, HeaderTimeMustBeSet) {
  robot_state_t r{};
  EXPECT_TRUE(validate(r));
  r.header.utime = 5;
  EXPECT_FALSE(validate(r));
}

TEST(Validate, NonFiniteValuesAreNamed) {
  robot_state_t r{};
  r.header.utime = 5;
  r.covariance[4] = kNan;
  ASSERT_TRUE(validate(r));
  EXPECT_EQ(*validate(r), "covariance[4] is not finite (nan)");
  line_contours_t l{};
  l.header.utime = 5;
  l.num_points = 2;
  l.u = {1, 2};
  l.v = {1, 2};
  l.x = {1, static_cast<float>(kNan)};
  l.y = {1, 2};
  EXPECT_EQ(*validate(l), "x[1] is not finite (nan)");
}

TEST(Validate, SequencesMustIndexPoints) {
  line_contours_t l{};
  l.header.utime = 5;
  l.num_points = 2;
  l.u = l.v = l.x = l.y = {0, 0};
  l.num_sequences = 1;
  l.sequence_start = {0};
  l.sequence_end = {3};
  EXPECT_TRUE(validate(l));
  l.sequence_end = {2};
  EXPECT_FALSE(validate(l));
}

TEST(Validate, FeatureHypothesesReferToFeatures) {
  field_features_t f{};
  f.header.utime = 5;
  f.num_hypotheses = 1;
  f.hypothesis_feature = {0};
  f.pose_x = f.pose_y = f.pose_phi = f.sigma_xy = f.sigma_phi = {0};
  EXPECT_TRUE(validate(f));
}

}  // namespace validate_test
}  // namespace fieldline::bus

#include "common/bus/cli.hpp"

namespace fieldline::bus {
namespace validate_test {

TEST(ParseNumberList, ExactCountOfFiniteNumbers) {
  EXPECT_EQ(parseNumberList("1.0,-0.5,0.2", 3, "--pose"), (std::vector<double>{1.0, -0.5, 0.2}));
  EXPECT_THROW(parseNumberList("1.0,-0.5", 3, "--pose"), std::invalid_argument);
  EXPECT_THROW(parseNumberList("1.0,x,0.2", 3, "--pose"), std::invalid_argument);
  EXPECT_THROW(parseNumberList("1.0,,0.2", 3, "--pose"), std::invalid_argument);
  EXPECT_THROW(parseNumberList("1,2,nan", 3, "--pose"), std::invalid_argument);
  EXPECT_THROW(parseNumberList("1,2,3,4", 3, "--pose"), std::invalid_argument);
  try {
    parseNumberList("1", 2, "--ball");
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "--ball expects 2 comma-separated numbers, got '1'");
  }
}

}  // namespace validate_test
}  // namespace fieldline::bus
