// Hostile bytes for every one of the 14 message types: truncated buffers, and for every array count
// and string length on the wire a negative, an absurd and (strings) a zero value. The hardened
// decoders (cmake/harden_lcm_decode.py) refuse each without throwing or allocating, the node
// counts each as a "decode" error and calls no handler, and the next good message arrives intact
// in the node's reused message object.
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <fieldline/header_t.hpp>

#include "common/bus/channels.hpp"
#include "common/bus/node.hpp"
#include "common/time/clock.hpp"

namespace fieldline::bus {
namespace {

constexpr Utime kNow = 1'800'000'000'000'000;
// Where a message's own fields start on the wire: the 8-byte fingerprint, then header_t
// (utime 8 + utime_published 8 + seq 8 + robot_id 1 + publisher_id 8).
constexpr std::size_t kBody = 8 + 33;

// An int32 on the wire that sizes what follows: an array count or a string length (with its NUL).
struct WireLength {
  std::string name;
  std::size_t offset;
  std::int32_t value;  // in the sample, to prove the offset right
  bool is_string = false;
};

header_t header() {
  header_t h{};
  h.utime = kNow - 1000;
  h.utime_published = kNow;
  h.robot_id = 1;
  return h;
}

// One valid sample per type, its channel, and the offsets of its wire lengths (arrays filled, so
// that every length is followed by data a wrong length would misread).
template <typename Msg>
struct Sample;

template <>
struct Sample<ball_observation_t> {
  static constexpr auto kChannel = channels::kVisionBall;
  static ball_observation_t make() {
    ball_observation_t m{};
    m.header = header();
    m.visible = true;
    m.x = 1.5f;
    m.confidence = 0.5f;
    return m;
  }
  static std::vector<WireLength> lengths() { return {}; }
};

template <>
struct Sample<ball_state_t> {
  static constexpr auto kChannel = channels::kBallState;
  static ball_state_t make() {
    ball_state_t m{};
    m.header = header();
    m.valid = true;
    m.covariance[0] = m.covariance[3] = 0.01;
    return m;
  }
  static std::vector<WireLength> lengths() { return {}; }
};

template <>
struct Sample<motion_command_t> {
  static constexpr auto kChannel = channels::kMotionCommand;
  static motion_command_t make() {
    motion_command_t m{};
    m.header = header();
    m.vx = 0.5;
    m.deadline_utime = kNow + 100'000;
    m.source = motion_command_t::SOURCE_PILOT;
    return m;
  }
  static std::vector<WireLength> lengths() { return {}; }
};

template <>
struct Sample<odometry_t> {
  static constexpr auto kChannel = channels::kOdometry;
  static odometry_t make() {
    odometry_t m{};
    m.header = header();
    m.wheel_count = 4;
    m.ticks = {10, -20, 30, -40};
    m.wheel_current = {0.5f, 0.0f, -0.5f, 1.0f};
    m.dx = 0.01;
    // The gyro's tail is the message's last field: a cut through it must be refused too.
    m.status = int{odometry_t::STATUS_GYRO} | int{odometry_t::STATUS_CURRENTS};
    m.gyro_dphi = 0.002;
    return m;
  }
  // wheel_count sizes both arrays.
  static std::vector<WireLength> lengths() { return {{"wheel_count", kBody, 4}}; }
};

template <>
struct Sample<robot_state_t> {
  static constexpr auto kChannel = channels::kRobotState;
  static robot_state_t make() {
    robot_state_t m{};
    m.header = header();
    m.x = 1;
    m.covariance[0] = 0.01;
    m.status = robot_state_t::STATUS_TRACKING;
    return m;
  }
  static std::vector<WireLength> lengths() { return {}; }
};

template <>
struct Sample<obstacle_observations_t> {
  static constexpr auto kChannel = channels::kVisionObstacles;
  static obstacle_observations_t make() {
    obstacle_observations_t m{};
    m.header = header();
    m.count = 2;
    m.bearing = {0.1f, 0.2f};
    m.distance = {1, 2};
    m.angular_width = {0.1f, 0.1f};
    m.width = {0.4f, 0.4f};
    m.x = {1, 2};
    m.y = {0, 0};
    return m;
  }
  static std::vector<WireLength> lengths() { return {{"count", kBody, 2}}; }
};

template <>
struct Sample<image_t> {
  static constexpr auto kChannel = channels::kCameraImage;
  static image_t make() {
    image_t m{};
    m.header = header();
    m.width = 4;
    m.height = 2;
    m.stride = 8;
    m.format = image_t::FORMAT_YUYV;
    m.source = image_t::SOURCE_SIM;
    m.size = 16;
    m.data.assign(16, 128);
    return m;
  }
  // width, height, stride 4 each, format and source 1 each, frame_number 8, exposure_us 4.
  static std::vector<WireLength> lengths() { return {{"size", kBody + 26, 16}}; }
};

template <>
struct Sample<line_contours_t> {
  static constexpr auto kChannel = channels::kVisionLines;
  static line_contours_t make() {
    line_contours_t m{};
    m.header = header();
    m.num_points = 3;
    m.u = m.v = {1, 2, 3};
    m.x = m.y = {0.5f, 0.6f, 0.7f};
    m.num_sequences = 1;
    m.sequence_start = {0};
    m.sequence_end = {3};
    m.image_width = 320;
    m.image_height = 240;
    m.touched_fraction = 0.1f;
    return m;
  }
  // Four float arrays of num_points before num_sequences.
  static std::vector<WireLength> lengths() {
    return {{"num_points", kBody, 3}, {"num_sequences", kBody + 4 + 16 * 3, 1}};
  }
};

template <>
struct Sample<field_features_t> {
  static constexpr auto kChannel = channels::kFieldFeatures;
  static field_features_t make() {
    field_features_t m{};
    m.header = header();
    m.num_features = 2;
    m.kind = {field_features_t::KIND_CENTER_CIRCLE, field_features_t::KIND_PENALTY_CORNER};
    m.feature_x = m.feature_y = m.feature_phi = m.quality = {0.5f, 0.5f};
    m.num_hypotheses = 1;
    m.hypothesis_feature = {0};
    m.pose_x = m.pose_y = m.pose_phi = m.sigma_xy = m.sigma_phi = {0.1f};
    return m;
  }
  // A feature takes kind 1 + four floats 16 bytes.
  static std::vector<WireLength> lengths() {
    return {{"num_features", kBody, 2}, {"num_hypotheses", kBody + 4 + 17 * 2, 1}};
  }
};

template <>
struct Sample<team_state_t> {
  static constexpr auto kChannel = channels::kTeamState;
  static team_state_t make() {
    team_state_t m{};
    m.header = header();
    m.num_robots = 2;
    m.present = {true, false};
    m.robot_x = m.robot_y = m.robot_phi = {1, 2};
    m.robot_sigma_xy = {0.1f, 0.1f};
    m.robot_age_us = m.ball_age_us = m.clock_offset_us = m.round_trip_us = {1, 2};
    m.ball_valid = {false, false};
    m.ball_x = m.ball_y = {0, 0};
    m.packets_received = m.packets_rejected = {3, 4};
    m.robot_twin_ambiguous = {false, true};
    return m;
  }
  static std::vector<WireLength> lengths() { return {{"num_robots", kBody, 2}}; }
};

template <>
struct Sample<world_state_t> {
  static constexpr auto kChannel = channels::kSimWorld;
  static world_state_t make() {
    world_state_t m{};
    m.header = header();
    m.field = "msl";
    m.scenario = "s";
    m.num_robots = 2;
    m.robot_id = {1, 2};
    m.robot_x = m.robot_y = m.robot_phi = m.robot_vx = m.robot_vy = m.robot_omega = {1, 2};
    m.robot_kidnaps = {0, 0};
    m.robot_radius = 0.25f;
    m.num_opponents = 1;
    m.opponent_x = m.opponent_y = m.opponent_phi = {3};
    m.opponent_radius = {0.25f};
    m.ball_radius = 0.11f;
    return m;
  }
  // Strings are a length (with the NUL) and the bytes; a robot takes 1 + 6 * 8 + 4 bytes.
  static std::vector<WireLength> lengths() {
    return {{"field", kBody, 4, true},
            {"scenario", kBody + 8, 2, true},
            {"num_robots", kBody + 14, 2},
            {"num_opponents", kBody + 18 + 53 * 2 + 4, 1}};
  }
};

template <>
struct Sample<service_status_t> {
  static constexpr auto kChannel = channels::kServiceStatus;
  static service_status_t make() {
    service_status_t m{};
    m.header = header();
    m.process = "p";
    m.num_channels = 2;
    m.channel = {"A", "B"};
    m.direction = {service_status_t::DIRECTION_IN, service_status_t::DIRECTION_OUT};
    m.messages_total = m.drops_total = m.rejected_total = {1, 2};
    m.rate_hz = m.latency_p50_ms = m.latency_p95_ms = m.latency_max_ms = {1, 2};
    m.num_errors = 1;
    m.error_kind = {"e"};
    m.error_count = {1};
    m.last_error = "x";
    m.num_metrics = 1;
    m.metric_name = {"m"};
    m.metric_value = {1};
    return m;
  }
  // process 4 + 2; pid 4, uptime_us 8, period_us 8, state 1; a channel takes its name 4 + 2 and
  // 1 + 8 + 4 + 8 + 8 + 3 * 4 bytes; processing 3 * 4; an error takes 4 + 2 + 8 bytes.
  static std::vector<WireLength> lengths() {
    constexpr std::size_t channels_at = kBody + 6 + 21;
    constexpr std::size_t errors_at = channels_at + 4 + 2 * (6 + 41) + 12;
    constexpr std::size_t last_error_at = errors_at + 4 + 14;
    constexpr std::size_t metrics_at = last_error_at + 6 + 8;
    return {{"process", kBody, 2, true},
            {"num_channels", channels_at, 2},
            {"channel[0]", channels_at + 4, 2, true},
            {"channel[1]", channels_at + 10, 2, true},
            {"num_errors", errors_at, 1},
            {"error_kind[0]", errors_at + 4, 2, true},
            {"last_error", last_error_at, 2, true},
            {"num_metrics", metrics_at, 1},
            {"metric_name[0]", metrics_at + 4, 2, true}};
  }
};

template <>
struct Sample<recording_info_t> {
  static constexpr auto kChannel = channels::kRecordingInfo;
  static recording_info_t make() {
    recording_info_t m{};
    m.header = header();
    m.format_version = recording_info_t::FORMAT_VERSION;
    m.bus_robot_id = 1;
    m.host = "h";
    m.version = "v";
    m.field_name = "f";
    m.field_yaml = "y";
    m.settings_yaml = "s";
    m.num_channels = 1;
    m.channels = {"A"};
    return m;
  }
  // format_version 4, bus_robot_id 1, clock_model 1, four int64/double 32, observed messages 4;
  // then five strings of 4 + 2 bytes.
  static std::vector<WireLength> lengths() {
    constexpr std::size_t strings_at = kBody + 42;
    return {{"host", strings_at, 2, true},
            {"version", strings_at + 6, 2, true},
            {"field_name", strings_at + 12, 2, true},
            {"field_yaml", strings_at + 18, 2, true},
            {"settings_yaml", strings_at + 24, 2, true},
            {"num_channels", strings_at + 30, 1},
            {"channels[0]", strings_at + 34, 2, true}};
  }
};

template <typename Msg>
std::vector<std::uint8_t> encode(const Msg& m) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  return buf;
}

std::int32_t readInt32(const std::vector<std::uint8_t>& buf, std::size_t offset) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i)
    v = (v << 8) | buf.at(offset + i);
  return static_cast<std::int32_t>(v);
}

void writeInt32(std::vector<std::uint8_t>& buf, std::size_t offset, std::int32_t value) {
  const auto v = static_cast<std::uint32_t>(value);
  for (std::size_t i = 0; i < 4; ++i)
    buf.at(offset + i) = static_cast<std::uint8_t>(v >> (24 - 8 * i));
}

// The decoder's verdict on bytes: its return value, or a note that it threw.
template <typename Msg>
::testing::AssertionResult refused(const std::vector<std::uint8_t>& buf, std::size_t size) {
  Msg m{};
  try {
    const int used = m.decode(buf.data(), 0, static_cast<int>(size));
    if (used < 0) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "decoded " << used << " of " << size << " bytes";
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw " << e.what();
  }
}

template <typename Msg>
class HostileInputEveryType : public ::testing::Test {
 protected:
  HostileInputEveryType() {
    receiver.subscribe(Sample<Msg>::kChannel, [this](const Msg& m) {
      ++handled;
      last_delivered = encode(m);
    });
  }

  void send(const std::vector<std::uint8_t>& buf, std::size_t size) {
    sender.publishEncoded(Sample<Msg>::kChannel.name, buf.data(), static_cast<int>(size));
    while (receiver.spinOnce(0) > 0) {
    }
  }
  void sendGoodAndExpectItIntact() {
    const auto good = encode(Sample<Msg>::make());
    const int before = handled;
    send(good, good.size());
    EXPECT_EQ(handled, before + 1);
    EXPECT_EQ(last_delivered, good) << "the reused message kept something of a refused one";
  }

  SimulatedClock clock{kNow};
  std::shared_ptr<Connection> memq = Connection::open("memq://");
  Node sender{{.process = "s", .robot_id = 1, .status_period_us = 0}, clock, memq};
  Node receiver{{.process = "r", .robot_id = 1, .status_period_us = 0}, clock, memq};
  int handled = 0;
  std::vector<std::uint8_t> last_delivered;
};

using AllMessageTypes =
    ::testing::Types<ball_observation_t, ball_state_t, field_features_t, image_t, line_contours_t,
                     motion_command_t, obstacle_observations_t, odometry_t, robot_state_t,
                     recording_info_t, service_status_t, team_state_t, world_state_t>;
TYPED_TEST_SUITE(HostileInputEveryType, AllMessageTypes);

TYPED_TEST(HostileInputEveryType, TheSampleIsValidAndItsLengthOffsetsAreRight) {
  const auto buf = encode(Sample<TypeParam>::make());
  for (const WireLength& length : Sample<TypeParam>::lengths())
    EXPECT_EQ(readInt32(buf, length.offset), length.value) << length.name;
  this->sendGoodAndExpectItIntact();
  EXPECT_EQ(this->receiver.status().errorCount("decode"), 0);
  EXPECT_EQ(this->receiver.status().errorCount("invalid"), 0);
}

TYPED_TEST(HostileInputEveryType, EveryTruncationIsRefusedAndCounted) {
  const auto buf = encode(Sample<TypeParam>::make());
  for (std::size_t size = 0; size < buf.size(); ++size)
    EXPECT_TRUE(refused<TypeParam>(buf, size)) << "truncated to " << size << " bytes";
  // Through the node: a message cut anywhere is a decode error, never a call.
  const std::vector<std::size_t> cuts{1, 8, kBody, buf.size() / 2, buf.size() - 1};
  for (std::size_t size : cuts)
    this->send(buf, size);
  EXPECT_EQ(this->handled, 0);
  EXPECT_EQ(this->receiver.status().errorCount("decode"), static_cast<std::int64_t>(cuts.size()));
  this->sendGoodAndExpectItIntact();
}

TYPED_TEST(HostileInputEveryType, NegativeAndAbsurdLengthsAreRefusedAndCounted) {
  const auto good = encode(Sample<TypeParam>::make());
  std::int64_t sent = 0;
  for (const WireLength& length : Sample<TypeParam>::lengths()) {
    std::vector<std::int32_t> values{-1, std::numeric_limits<std::int32_t>::min(),
                                     std::numeric_limits<std::int32_t>::max(), 0x20000000,
                                     static_cast<std::int32_t>(good.size())};
    if (length.is_string) values.push_back(0);  // a wire string holds at least its NUL
    for (std::int32_t value : values) {
      auto buf = good;
      writeInt32(buf, length.offset, value);
      EXPECT_TRUE(refused<TypeParam>(buf, buf.size())) << length.name << " = " << value;
      this->send(buf, buf.size());
      ++sent;
    }
  }
  EXPECT_EQ(this->handled, 0);
  EXPECT_EQ(this->receiver.status().errorCount("decode"), sent);
  this->sendGoodAndExpectItIntact();
}

TEST(HostileInputHeader, EveryTruncationIsRefused) {
  header_t h = header();
  h.seq = 7;
  const auto buf = encode(h);
  for (std::size_t size = 0; size < buf.size(); ++size)
    EXPECT_TRUE(refused<header_t>(buf, size)) << "truncated to " << size << " bytes";
  header_t back{};
  EXPECT_EQ(back.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  EXPECT_EQ(back.seq, 7);
}

// Every type in lcmtypes/ is covered above: 13 message types and header_t (14 channels:
// CAMERA_PREVIEW carries an image_t like CAMERA_IMAGE).
static_assert(std::tuple_size_v<decltype(kAllChannelNames)> == 14);

}  // namespace
}  // namespace fieldline::bus
