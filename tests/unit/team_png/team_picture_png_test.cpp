#include "tools/team_png/team_picture_png.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace fieldline::team_png {
namespace {

cv::Vec3b at(const cv::Mat& image, const cv::Point& p) {
  return image.at<cv::Vec3b>(p.y, p.x);
}

cv::Vec3b asPixel(const cv::Scalar& s) {
  return {static_cast<uchar>(s[0]), static_cast<uchar>(s[1]), static_cast<uchar>(s[2])};
}

class TeamPicturePng : public ::testing::Test {
 protected:
  field::FieldModel field = field::loadFieldPreset("msl");
  double scale = 20.0;
  perception::TeamState picture;

  void SetUp() override {
    auto& r2 = picture.robots[1];
    r2.present = true;
    r2.x = 3.0;
    r2.y = -2.0;
    r2.phi = M_PI;  // the heading line points away from the probe pixel below
    r2.sigma_xy = 0.1f;
    picture.team_ball_valid = true;
    picture.team_ball_x = -4.0;
    picture.team_ball_y = 1.5;
    picture.team_ball_covariance = Eigen::Matrix2d::Identity() * 0.01;
  }
};

TEST_F(TeamPicturePng, DrawsPresentRobotsInTheirColourAndTheTeamBallInOrange) {
  const cv::Mat image = drawTeamPicture(field, picture, 1, nullptr, scale);
  const field::Vec2 half = field.carpetHalfExtent();
  EXPECT_EQ(image.cols, static_cast<int>(std::ceil(2 * half.x() * scale)));
  EXPECT_EQ(image.rows, static_cast<int>(std::ceil(2 * half.y() * scale)) + kLegendRows);
  // Inside robot 2's disc, off its heading line and its number.
  const cv::Point r2 = fieldPixel(field, scale, {3.0, -2.0 - 0.15});
  EXPECT_EQ(at(image, r2), asPixel(kRobotColours[1]));
  EXPECT_EQ(at(image, fieldPixel(field, scale, {-4.0, 1.5})), asPixel(kTeamBallColour));
  // Robot 1 is absent: its spot is carpet.
  const cv::Vec3b carpet = at(image, fieldPixel(field, scale, {3.0, 2.0}));
  EXPECT_EQ(carpet, cv::Vec3b(40, 120, 40));
}

TEST_F(TeamPicturePng, NoTeamBallNoOrangeAndTruthIsDrawnAsGreyRings) {
  picture.team_ball_valid = false;
  perception::WorldTruth truth;
  truth.robots.push_back({1, {-2.0, -3.0, 0.0}, field::Vec2::Zero(), 0.0, 0});
  const cv::Mat image = drawTeamPicture(field, picture, 1, &truth, scale);
  EXPECT_NE(at(image, fieldPixel(field, scale, {-4.0, 1.5})), asPixel(kTeamBallColour));
  // The truth ring of radius 0.32 m crosses the point 0.32 m right of the robot.
  const cv::Point ring = fieldPixel(field, scale, {-2.0 + 0.32, -3.0});
  const cv::Vec3b p = at(image, ring);
  EXPECT_GT(p[0], 100);
  EXPECT_NEAR(p[0], p[2], 40);  // grey-ish, not carpet green
}

}  // namespace
}  // namespace fieldline::team_png
