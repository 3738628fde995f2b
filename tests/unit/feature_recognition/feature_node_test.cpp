// The feature_recognition node over memq:// with a simulated clock: VISION_LINES in, one
// FIELD_FEATURES per message with the same utime, the centre circle's two poses in it; unsound
// messages are counted in SERVICE_STATUS and still answered.
#include "services/feature_recognition/feature_node.hpp"

#include <algorithm>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/msg/field_features.hpp"
#include "common/msg/line_contours.hpp"
#include "common/time/clock.hpp"
#include "tests/unit/feature_recognition/synthetic.hpp"

namespace fieldline::feature_recognition {
namespace feature_node_test {

// The value of the error kind or metric `name` in a SERVICE_STATUS message (-1 when absent).
double errorCount(const service_status_t& s, const std::string& name) {
  for (std::size_t i = 0; i < s.error_kind.size(); ++i) {
    if (s.error_kind[i] == name) return static_cast<double>(s.error_count[i]);
  }
  return -1;
}
double metric(const service_status_t& s, const std::string& name) {
  for (std::size_t i = 0; i < s.metric_name.size(); ++i) {
    if (s.metric_name[i] == name) return s.metric_value[i];
  }
  return -1;
}

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
  EXPECT_EQ(errorCount(status, "overlapping_sequences"), 1);
  EXPECT_EQ(errorCount(status, "too_many_points"), 1);
  EXPECT_GE(metric(status, "circles_per_s"), 1.0);
}

TEST(FeatureNode, CountsEveryKindOfBadInputAndTheModelCheckRejectionsInTheStatus) {
  const field::FieldModel field = field::loadFieldPreset("msl");
  SimulatedClock clock{1'800'000'000'000'000};
  auto memq = bus::Connection::open("memq://");
  bus::Node vision{
      {.process = "region_tracking", .robot_id = 2, .status_period_us = 0}, clock, memq};
  bus::Node recogniser{
      {.process = "feature_recognition", .robot_id = 2, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 2, .status_period_us = 0}, clock, memq};
  FeatureNode node(recogniser, field);
  int answers = 0;
  listener.subscribe(bus::channels::kFieldFeatures, [&](const field_features_t&) { ++answers; });
  service_status_t status{};
  listener.subscribe(bus::channels::kServiceStatus, [&](const service_status_t& m) {
    if (m.process == "feature_recognition") status = m;
  });
  auto stamped = [&](const perception::LinePoints& points) {
    clock.advance(100'000);
    line_contours_t m{};
    m.header.utime = clock.now() - 40'000;
    msg::toMessage(points, m);
    return m;
  };
  auto deliver = [&] {
    recogniser.spinOnce(0);
    listener.spinOnce(0);
  };
  auto send = [&](const perception::LinePoints& points) {
    line_contours_t m = stamped(points);
    vision.publish(bus::channels::kVisionLines, m);
    deliver();
  };
  // Bytes the bus's validation refuses (the sender's publish would refuse them too): sent
  // encoded, as a broken or hostile publisher would.
  auto sendEncoded = [&](line_contours_t m) {
    m.header.robot_id = 2;
    m.header.utime_published = clock.now();
    m.header.publisher_id = 77;
    m.header.seq = 1;
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    vision.publishEncoded(bus::channels::kVisionLines.name, bytes.data(),
                          static_cast<int>(bytes.size()));
    deliver();
  };

  const geometry::Pose2 pose{-1.0, 0.5, 0.4};
  const perception::LinePoints good = test::frameAt(field, pose, 5.0, 0.08, 0.01, 1);
  // NaN and an infinite coordinate: rejected by the bus, counted, not answered.
  line_contours_t nan_message = stamped(good);
  nan_message.x[3] = std::numeric_limits<float>::quiet_NaN();
  sendEncoded(nan_message);
  line_contours_t inf_message = stamped(good);
  inf_message.y[5] = std::numeric_limits<float>::infinity();
  sendEncoded(inf_message);
  // A sequence beyond the points: rejected by the bus.
  line_contours_t outside = stamped(good);
  outside.sequence_end[0] = outside.num_points + 5;
  sendEncoded(outside);
  EXPECT_EQ(answers, 0);
  EXPECT_EQ(node.framesProcessed(), 0);

  // Sound messages whose sequences the recogniser refuses: two overlapping sequences in one
  // frame, and an empty sequence list of 100,000 points.
  perception::LinePoints overlapping = good;
  overlapping.sequences.emplace_back(0, 20);
  overlapping.sequences.emplace_back(5, 25);
  send(overlapping);
  perception::LinePoints huge;
  huge.points.resize(100'000, {0, 0, 1.0f, 1.0f});
  huge.sequences.emplace_back(0, 100'000);
  send(huge);
  send(huge);

  // The centre circle with its line, among as many white streaks that fit no field line at the
  // pose it implies: the model check refuses it.
  perception::LinePoints cluttered = good;
  std::mt19937 rng(5);
  for (int k = 0; k < 12; ++k) {
    const double a = 0.6 + 0.21 * k;
    const Vec2 from = (1.2 + 0.25 * k) * Vec2(std::cos(a), std::sin(a));
    const Vec2 to = from + 1.2 * Vec2(std::cos(2.0 * a + 0.3), std::sin(2.0 * a + 0.3));
    test::addSequence(cluttered, test::polyline({from, to}, 0.08, 0.005, rng));
  }
  FeatureRecognizer reference(field);
  perception::FieldFeatures reference_out;
  reference.recognize(cluttered, reference_out);
  int refused = 0;
  for (const CheckedFeature& c : reference.checked())
    refused += c.accepted ? 0 : 1;
  ASSERT_GE(refused, 1) << "the test frame must make the model check refuse something";
  send(cluttered);
  send(cluttered);

  EXPECT_EQ(answers, 5);
  EXPECT_EQ(node.framesProcessed(), 5);
  EXPECT_EQ(node.framesWithErrors(), 3);
  EXPECT_EQ(node.droppedSequences(), 2);
  EXPECT_EQ(node.modelCheckRejections(), 2 * refused);

  recogniser.publishStatus();
  listener.spinOnce(0);
  ASSERT_EQ(status.process, "feature_recognition");
  EXPECT_EQ(errorCount(status, "invalid"), 3);
  std::int64_t rejected = -1;
  for (std::size_t i = 0; i < status.channel.size(); ++i) {
    if (status.channel[i] == bus::channels::kVisionLines.name) rejected = status.rejected_total[i];
  }
  EXPECT_EQ(rejected, 3);
  EXPECT_EQ(errorCount(status, "overlapping_sequences"), 1);
  EXPECT_EQ(errorCount(status, "too_many_points"), 2);
  EXPECT_EQ(errorCount(status, "non_finite_sequences"), -1);
  EXPECT_EQ(metric(status, "dropped_sequences_total"), 2);
  EXPECT_EQ(metric(status, "model_check_rejected_total"), 2 * refused);
  EXPECT_EQ(metric(status, "model_check_rejected_circle_total") +
                metric(status, "model_check_rejected_corner_total"),
            2 * refused);
  // Input errors put the process into WARN with the reason; model-check rejections alone do not.
  EXPECT_EQ(status.state, service_status_t::STATE_WARN);
  send(cluttered);
  recogniser.publishStatus();
  listener.spinOnce(0);
  EXPECT_EQ(status.state, service_status_t::STATE_OK) << status.state_reason;
  EXPECT_EQ(metric(status, "model_check_rejected_total"), 3 * refused);
}

}  // namespace feature_node_test
}  // namespace fieldline::feature_recognition
