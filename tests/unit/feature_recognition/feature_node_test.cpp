// The feature_recognition node over memq:// with a simulated clock: VISION_LINES in, one
// FIELD_FEATURES per message with the same utime, the centre circle's two poses in it; unsound
// messages are counted in SERVICE_STATUS and still answered.
#include "services/feature_recognition/feature_node.hpp"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/msg/field_features.hpp"
#include "common/msg/line_contours.hpp"
#include "common/time/clock.hpp"
#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace {

TEST(FeatureNode, AnswersEveryVisionLinesMessageWithItsUtime) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  SimulatedClock clock{1'800'000'000'000'000};
  auto memq = bus::Connection::open("memq://");
  bus::Node vision{
      {.process = "region_tracking", .robot_id = 3, .status_period_us = 0}, clock, memq};
  bus::Node recogniser{
      {.process = "feature_recognition", .robot_id = 3, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 3, .status_period_us = 0}, clock, memq};
  FeatureNode node(recogniser, field);

  std::vector<Utime> times;
  std::vector<perception::FieldFeatures> received;
  listener.subscribe(bus::channels::kFieldFeatures, [&](const field_features_t& m) {
    times.push_back(m.header.utime);
    received.push_back({});
    msg::fromMessage(m, received.back());
  });
  service_status_t status{};
  listener.subscribe(bus::channels::kServiceStatus, [&](const service_status_t& m) {
    if (m.process == "feature_recognition") status = m;
  });

  const geometry::Pose2 pose{-1.0, 0.5, 0.4};
  auto send = [&](const perception::LinePoints& points) {
    clock.advance(100'000);
    line_contours_t m{};
    m.header.utime = clock.now() - 40'000;
    msg::toMessage(points, m);
    vision.publish(bus::channels::kVisionLines, m);
    recogniser.spinOnce(0);
    listener.spinOnce(0);
    return m.header.utime;
  };
  std::vector<Utime> sent;
  sent.push_back(send(test::frameAt(field, pose, 5.0, 0.08, 0.01, 1)));
  sent.push_back(send({}));  // an empty frame: answered, nothing in it
  // Overlapping sequences (the bus checks sizes and finiteness, not overlaps): dropped, counted.
  perception::LinePoints overlapping = test::frameAt(field, pose, 5.0, 0.08, 0.01, 2);
  overlapping.sequences.emplace_back(0, 20);
  sent.push_back(send(overlapping));
  // 100,000 points: refused whole, counted, still answered (empty).
  perception::LinePoints huge;
  huge.points.resize(100'000, {0, 0, 1.0f, 1.0f});
  huge.sequences.emplace_back(0, 100'000);
  sent.push_back(send(huge));

  ASSERT_EQ(times, sent);
  EXPECT_EQ(node.framesProcessed(), 4);
  EXPECT_EQ(node.framesWithErrors(), 2);
  // Frame 1: the centre circle with its two poses, one of them the truth.
  int circles = 0;
  for (const auto& f : received[0].features) {
    circles += f.kind == perception::FeatureKind::kCentreCircle;
  }
  EXPECT_EQ(circles, 1);
  ASSERT_GE(received[0].hypotheses.size(), 2u);
  const double nearest =
      std::min((received[0].hypotheses[0].pose.position() - pose.position()).norm(),
               (received[0].hypotheses[1].pose.position() - pose.position()).norm());
  EXPECT_LT(nearest, 0.05);
  EXPECT_TRUE(received[1].features.empty());
  EXPECT_FALSE(received[2].hypotheses.empty());  // the sound sequences are still used
  EXPECT_TRUE(received[3].features.empty());

  recogniser.publishStatus();
  listener.spinOnce(0);
  std::int64_t errors = 0;
  for (std::size_t i = 0; i < status.error_kind.size(); ++i) {
    if (status.error_kind[i] == "bad_sequences" || status.error_kind[i] == "too_many_points") {
      errors += status.error_count[i];
    }
  }
  EXPECT_EQ(errors, 2);
  bool rate = false;
  for (std::size_t i = 0; i < status.metric_name.size(); ++i) {
    if (status.metric_name[i] == "circles_per_s") rate = status.metric_value[i] >= 1.0;
  }
  EXPECT_TRUE(rate);
}

}  // namespace
}  // namespace fieldline::feature_recognition
