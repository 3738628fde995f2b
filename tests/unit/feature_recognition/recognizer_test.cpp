// The whole recogniser and its pose hypotheses on frames sampled from the field model: the right
// poses (both symmetric ones), no false ones anywhere on the field or with clutter, bad input.
#include "services/feature_recognition/recognizer.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "services/feature_recognition/pose_hypotheses.hpp"
#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace recognizer_test {

using geometry::Pose2;
using perception::FeatureKind;
constexpr double kPi = std::numbers::pi;

// Position and heading error against the nearer of the pose and its point-symmetric twin.
std::pair<double, double> errorOf(const Pose2& truth, const Pose2& h) {
  const Pose2 twin{-truth.x, -truth.y, geometry::normalizeAngle(truth.phi + kPi)};
  const double e1 = (h.position() - truth.position()).norm();
  const double e2 = (h.position() - twin.position()).norm();
  const Pose2& near = e1 <= e2 ? truth : twin;
  return {std::min(e1, e2), std::abs(geometry::angleDiff(h.phi, near.phi))};
}

TEST(PoseHypotheses, QualityMeasureAndMarks) {
  EXPECT_DOUBLE_EQ(qualityMeasure(0, 2), 1.0);
  EXPECT_LT(qualityMeasure(0, 12), qualityMeasure(0, 2));
  EXPECT_LT(qualityMeasure(1, 17), qualityMeasure(0, 12));
  // The robot at (2, 1, 90 deg) sees the mark (0, 0, 90 deg) 2 m to its left... its local pose.
  const Pose2 robot{2.0, 1.0, kPi / 2};
  const Pose2 mark{0.0, 0.0, kPi / 2};
  const Pose2 local = geometry::poseFieldToRobot(robot, mark);
  const Pose2 back = robotPoseFrom(mark, local);
  EXPECT_NEAR(back.x, 2.0, 1e-12);
  EXPECT_NEAR(back.y, 1.0, 1e-12);
  EXPECT_NEAR(back.phi, kPi / 2, 1e-12);
  const field::FieldModel field = field::loadFieldPreset("msl");
  const auto corners = penaltyCornerMarks(field, true, false);
  ASSERT_EQ(corners.size(), 2u);
  EXPECT_GT(corners[0].x, 0);
  EXPECT_GT(corners[0].y, 0);  // left of the opponent goal seen from the field is +y
  EXPECT_NEAR(corners[1].x, -corners[0].x, 1e-12);
  EXPECT_NEAR(corners[1].y, -corners[0].y, 1e-12);
}

TEST(Recognizer, CentreCircleGivesTheTwoSymmetricPoses) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  FeatureRecognizer recognizer(field);
  const Pose2 pose{-0.8, 0.6, 0.7};
  perception::FieldFeatures out;
  const auto check = recognizer.recognize(test::frameAt(field, pose, 5.0, 0.08, 0.01), out);
  EXPECT_EQ(check.errors(), 0);
  int circles = 0;
  for (const auto& f : out.features)
    circles += f.kind == FeatureKind::kCentreCircle;
  ASSERT_EQ(circles, 1);
  ASSERT_GE(out.hypotheses.size(), 2u);
  // Best first: the circle's two poses, one the truth and one its twin.
  int near_truth = 0;
  for (int i = 0; i < 2; ++i) {
    const auto& h = out.hypotheses[i];
    EXPECT_EQ(out.features[h.feature].kind, FeatureKind::kCentreCircle);
    const auto [position, heading] = errorOf(pose, h.pose);
    EXPECT_LT(position, 0.02);
    EXPECT_LT(heading, 0.005);
    EXPECT_GE(h.sigma_xy, RecognitionParams{}.min_sigma_xy);
    EXPECT_GT(h.sigma_xy, 0.0);
    near_truth += (h.pose.position() - pose.position()).norm() < 0.05;
  }
  EXPECT_EQ(near_truth, 1);
}

TEST(Recognizer, NoFalseHypothesisAnywhereOnTheFieldWithOrWithoutClutter) {
  for (const char* preset : {"msl", "fu2004"}) {
    const field::FieldModel field = field::loadFieldPreset(preset);
    FeatureRecognizer recognizer(field);
    perception::FieldFeatures out;
    std::mt19937 rng(16);
    std::uniform_real_distribution<double> ux(-field.length() / 2 - 0.5, field.length() / 2 + 0.5);
    std::uniform_real_distribution<double> uy(-field.width() / 2 - 0.5, field.width() / 2 + 0.5);
    std::uniform_real_distribution<double> angle(-kPi, kPi), unit(0.0, 1.0);
    int frames_with_hypotheses = 0;
    for (int i = 0; i < 300; ++i) {
      const Pose2 pose{ux(rng), uy(rng), angle(rng)};
      auto points = test::frameAt(field, pose, 5.0, 0.08, 0.01, static_cast<std::uint32_t>(i));
      if (i % 2) {
        // Clutter: white streaks and round white things (robots, balls, up to 0.6 m) in the
        // robot frame. (A white arc of the centre circle's radius with a line through its
        // centre is the centre circle by definition.)
        for (int k = 0; k < 4; ++k) {
          const Vec2 a(6 * unit(rng) - 3, 6 * unit(rng) - 3);
          const Vec2 b = a + 1.5 * Vec2(std::cos(angle(rng)), std::sin(angle(rng)));
          test::addSequence(points, test::polyline({a, b}, 0.08, 0.01, rng));
          test::addSequence(points, test::arc(a, 0.15 + 0.45 * unit(rng), 0, 2.0, 0.05, 0.01, rng));
        }
      }
      recognizer.recognize(points, out);
      if (!out.hypotheses.empty()) ++frames_with_hypotheses;
      for (const auto& h : out.hypotheses) {
        const auto [position, heading] = errorOf(pose, h.pose);
        EXPECT_LT(position, 0.5) << preset << " frame " << i << " pose " << pose.x << "," << pose.y
                                 << "," << pose.phi << " kind "
                                 << int(out.features[h.feature].kind);
        EXPECT_LT(heading, 10 * kPi / 180) << preset << " frame " << i;
      }
    }
    EXPECT_GT(frames_with_hypotheses, 30) << preset;
  }
}

TEST(Recognizer, BadSequencesAreDroppedAndTheRestIsUsed) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  FeatureRecognizer recognizer(field);
  const Pose2 pose{0.5, -0.3, 2.0};
  auto points = test::frameAt(field, pose, 5.0, 0.08, 0.01);
  std::mt19937 rng(17);
  test::addSequence(points, test::polyline({{0, 0}, {1, 1}}, 0.1, 0.0, rng));
  points.points.back().x = std::numeric_limits<float>::infinity();
  points.sequences.emplace_back(0, 10);  // overlapping
  perception::FieldFeatures out;
  const auto check = recognizer.recognize(points, out);
  EXPECT_EQ(check.non_finite, 1);
  EXPECT_EQ(check.overlapping, 1);
  ASSERT_FALSE(out.hypotheses.empty());
  EXPECT_LT(errorOf(pose, out.hypotheses[0].pose).first, 0.05);
}

TEST(Recognizer, HugeAndEmptyFrames) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  FeatureRecognizer recognizer(field);
  perception::FieldFeatures out;
  perception::LinePoints huge;
  std::mt19937 rng(18);
  std::uniform_real_distribution<float> u(-5, 5);
  for (int i = 0; i < 100'000; ++i)
    huge.points.push_back({0, 0, u(rng), u(rng)});
  for (int i = 0; i < 100'000; i += 50)
    huge.sequences.emplace_back(i, i + 50);
  auto check = recognizer.recognize(huge, out);
  EXPECT_TRUE(check.too_many_points);
  EXPECT_TRUE(out.features.empty());
  // Just under the limit: answered (in bounded time), nothing false to check but no crash.
  huge.points.resize(RecognitionParams{}.max_points);
  huge.sequences.resize(RecognitionParams{}.max_points / 50);
  check = recognizer.recognize(huge, out);
  EXPECT_FALSE(check.too_many_points);
  EXPECT_EQ(check.errors(), 0);
  check = recognizer.recognize({}, out);
  EXPECT_EQ(check.errors(), 0);
  EXPECT_TRUE(out.features.empty());
  EXPECT_TRUE(out.hypotheses.empty());
}

TEST(Recognizer, HypothesesAreRankedByQualityThenSigma) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  FeatureRecognizer recognizer(field);
  perception::FieldFeatures out;
  recognizer.recognize(test::frameAt(field, {7.0, 0.3, 0.2}, 6.0, 0.08, 0.01), out);
  ASSERT_GE(out.hypotheses.size(), 4u);
  for (std::size_t i = 1; i < out.hypotheses.size(); ++i) {
    const auto& a = out.hypotheses[i - 1];
    const auto& b = out.hypotheses[i];
    const double qa = out.features[a.feature].quality, qb = out.features[b.feature].quality;
    EXPECT_TRUE(qa > qb || (qa == qb && a.sigma_xy <= b.sigma_xy));
  }
}

}  // namespace recognizer_test
}  // namespace fieldline::feature_recognition
