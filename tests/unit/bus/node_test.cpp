// The bus over memq:// with a simulated clock: typed round trip, header filling, drops from seq
// gaps, rejection of bad input, and the content of SERVICE_STATUS.
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"

namespace fieldline::bus {
namespace node_test {

class BusTest : public ::testing::Test {
 protected:
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<Connection> memq = Connection::open("memq://");
  Node sender{{.process = "sender", .robot_id = 3, .status_period_us = 0}, clock, memq};
  Node receiver{{.process = "receiver", .robot_id = 3, .status_period_us = 0}, clock, memq};

  static motion_command_t command(Utime utime, double vx) {
    motion_command_t m{};
    m.header.utime = utime;
    m.vx = vx;
    m.vy = -0.25;
    m.omega = 0.5;
    m.deadline_utime = utime + 100'000;
    m.source = motion_command_t::SOURCE_PILOT;
    return m;
  }
  void spin() {
    for (int i = 0; i < 5; ++i)
      receiver.spinOnce(0);
  }
};

TEST_F(BusTest, TypedRoundTripFillsTheHeader) {
  std::vector<motion_command_t> got;
  receiver.subscribe(channels::kMotionCommand,
                     [&](const motion_command_t& m) { got.push_back(m); });
  const Utime observed = clock.now() - 20'000;
  auto m = command(observed, 0.75);
  clock.advance(1000);
  ASSERT_TRUE(sender.publish(channels::kMotionCommand, m));
  auto m2 = command(observed + 5000, -1.0);
  ASSERT_TRUE(sender.publish(channels::kMotionCommand, m2));
  spin();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].header.utime, observed);
  EXPECT_EQ(got[0].header.utime_published, clock.now());
  EXPECT_EQ(got[0].header.seq, 0);
  EXPECT_EQ(got[1].header.seq, 1);
  EXPECT_EQ(got[0].header.robot_id, 3);
  EXPECT_DOUBLE_EQ(got[0].vx, 0.75);
  EXPECT_DOUBLE_EQ(got[0].vy, -0.25);
  EXPECT_DOUBLE_EQ(got[1].vx, -1.0);
  EXPECT_EQ(got[0].deadline_utime, observed + 100'000);
  const ChannelStats* in = receiver.status().channel("MOTION_COMMAND", Direction::kIn);
  ASSERT_NE(in, nullptr);
  EXPECT_EQ(in->total, 2);
  EXPECT_EQ(in->drops, 0);
}

TEST_F(BusTest, SeqIsPerChannel) {
  std::vector<std::int64_t> seqs;
  receiver.subscribe(channels::kBallState,
                     [&](const ball_state_t& m) { seqs.push_back(m.header.seq); });
  auto cmd = command(clock.now(), 0);
  sender.publish(channels::kMotionCommand, cmd);
  ball_state_t b{};
  b.header.utime = clock.now();
  sender.publish(channels::kBallState, b);
  sender.publish(channels::kBallState, b);
  spin();
  EXPECT_EQ(seqs, (std::vector<std::int64_t>{0, 1}));
}

// The constants take their index from the table (channels.hpp); a Channel made by hand with
// another channel's index still publishes under its own name: its seq and statistics, not the
// other channel's.
TEST_F(BusTest, AChannelMadeByHandWithAWrongIndexKeepsItsOwnSeq) {
  static_assert(kAllChannelNames[channels::kBallState.index] == channels::kBallState.name);
  std::vector<std::int64_t> balls, commands;
  receiver.subscribe(channels::kBallState,
                     [&](const ball_state_t& m) { balls.push_back(m.header.seq); });
  receiver.subscribe(channels::kMotionCommand,
                     [&](const motion_command_t& m) { commands.push_back(m.header.seq); });
  const Channel<ball_state_t> wrong{channels::kBallState.name, channels::kMotionCommand.index};
  auto cmd = command(clock.now(), 0);
  ball_state_t b{};
  b.header.utime = clock.now();
  ASSERT_TRUE(sender.publish(channels::kMotionCommand, cmd));
  ASSERT_TRUE(sender.publish(wrong, b));
  ASSERT_TRUE(sender.publish(channels::kBallState, b));
  ASSERT_TRUE(sender.publish(channels::kMotionCommand, cmd));
  spin();
  EXPECT_EQ(balls, (std::vector<std::int64_t>{0, 1}));
  EXPECT_EQ(commands, (std::vector<std::int64_t>{0, 1}));
  const ChannelStats* out = sender.status().channel("BALL_STATE", Direction::kOut);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(out->total, 2);
}

TEST_F(BusTest, SeqGapIsCountedAsDrops) {
  int handled = 0;
  receiver.subscribe(channels::kOdometry, [&](const odometry_t&) { ++handled; });
  odometry_t o{};
  o.header.utime = clock.now();
  o.header.robot_id = 2;
  std::vector<std::uint8_t> buf;
  for (std::int64_t seq : {0, 1, 2, 6, 7, 10}) {
    o.header.seq = seq;
    o.header.utime_published = clock.now();
    buf.resize(static_cast<std::size_t>(o.getEncodedSize()));
    o.encode(buf.data(), 0, static_cast<int>(buf.size()));
    sender.publishEncoded(channels::kOdometry.name, buf.data(), static_cast<int>(buf.size()));
  }
  spin();
  EXPECT_EQ(handled, 6);
  const ChannelStats* in = receiver.status().channel("ODOMETRY", Direction::kIn);
  ASSERT_NE(in, nullptr);
  EXPECT_EQ(in->drops, 3 + 2);
}

TEST_F(BusTest, SenderRestartIsNotALoss) {
  receiver.subscribe(channels::kOdometry, [&](const odometry_t&) {});
  odometry_t o{};
  o.header.utime = clock.now();
  std::vector<std::uint8_t> buf;
  for (std::int64_t seq : {40, 41, 0, 1}) {
    o.header.seq = seq;
    buf.resize(static_cast<std::size_t>(o.getEncodedSize()));
    o.encode(buf.data(), 0, static_cast<int>(buf.size()));
    sender.publishEncoded(channels::kOdometry.name, buf.data(), static_cast<int>(buf.size()));
  }
  spin();
  EXPECT_EQ(receiver.status().channel("ODOMETRY", Direction::kIn)->drops, 0);
}

TEST_F(BusTest, UndecodableBytesAreRejectedAndCounted) {
  int handled = 0;
  receiver.subscribe(channels::kMotionCommand, [&](const motion_command_t&) { ++handled; });
  const std::vector<std::uint8_t> garbage{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  sender.publishEncoded(channels::kMotionCommand.name, garbage.data(),
                        static_cast<int>(garbage.size()));
  // A valid message with its last byte cut off.
  auto m = command(clock.now(), 0.1);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sender.publishEncoded(channels::kMotionCommand.name, buf.data(),
                        static_cast<int>(buf.size()) - 1);
  spin();
  EXPECT_EQ(handled, 0);
  EXPECT_EQ(receiver.status().errorCount("decode"), 2);
  EXPECT_EQ(receiver.status().channel("MOTION_COMMAND", Direction::kIn)->rejected, 2);
  EXPECT_NE(receiver.status().lastError().find("MOTION_COMMAND"), std::string::npos);
}

TEST_F(BusTest, NanIsNeverPublishedNorHandled) {
  int handled = 0;
  receiver.subscribe(channels::kMotionCommand, [&](const motion_command_t&) { ++handled; });
  auto m = command(clock.now(), std::numeric_limits<double>::quiet_NaN());
  EXPECT_FALSE(sender.publish(channels::kMotionCommand, m));
  EXPECT_EQ(sender.status().errorCount("invalid_output"), 1);
  // Someone else's NaN arriving from the wire.
  m.header.seq = 0;
  m.header.utime_published = clock.now();
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sender.publishEncoded(channels::kMotionCommand.name, buf.data(), static_cast<int>(buf.size()));
  spin();
  EXPECT_EQ(handled, 0);
  EXPECT_EQ(receiver.status().errorCount("invalid"), 1);
  EXPECT_NE(receiver.status().lastError().find("vx is not finite"), std::string::npos)
      << receiver.status().lastError();
}

TEST_F(BusTest, OutOfRangeCommandPassesForTheBridgeToClamp) {
  std::vector<double> got;
  receiver.subscribe(channels::kMotionCommand,
                     [&](const motion_command_t& m) { got.push_back(m.vx); });
  auto m = command(clock.now(), 1.5);
  EXPECT_TRUE(sender.publish(channels::kMotionCommand, m));
  spin();
  EXPECT_EQ(got, std::vector<double>{1.5});
}

TEST_F(BusTest, UtimeFromTheFutureIsRejected) {
  std::vector<Utime> got;
  receiver.subscribe(channels::kMotionCommand,
                     [&](const motion_command_t& m) { got.push_back(m.header.utime); });
  auto future = command(clock.now() + 2 * kMicrosPerSecond, 0.1);
  sender.publish(channels::kMotionCommand, future);
  auto fine = command(clock.now() + 100'000, 0.1);  // within the 500 ms tolerance
  sender.publish(channels::kMotionCommand, fine);
  spin();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], fine.header.utime);
  EXPECT_EQ(receiver.status().errorCount("future_utime"), 1);
}

TEST_F(BusTest, TimersFireOnClockTime) {
  int ticks = 0;
  int once = 0;
  receiver.every(20'000, [&] { ++ticks; });
  receiver.at(clock.now() + 50'000, [&] { ++once; });
  for (int i = 0; i < 10; ++i) {
    clock.advance(10'000);
    receiver.spinOnce(0);
  }
  EXPECT_EQ(ticks, 5);
  EXPECT_EQ(once, 1);
}

TEST_F(BusTest, ServiceStatusReportsTrafficLatencyAndErrors) {
  SimulatedClock clock2{clock.now()};
  Node worker{
      {.process = "worker", .robot_id = 4, .status_period_us = kMicrosPerSecond}, clock2, memq};
  std::optional<service_status_t> status;
  receiver.subscribe(channels::kServiceStatus, [&](const service_status_t& s) {
    if (s.process == "worker") status = s;
  });
  worker.subscribe(channels::kMotionCommand, [&](const motion_command_t&) {});
  worker.setMetric("speed_mps", 1.25);
  // 10 commands in, each 30 ms old when published; 5 odometry out, 8 ms latency.
  for (int i = 0; i < 10; ++i) {
    auto m = command(clock2.now() - 30'000, 0.2);
    sender.publish(channels::kMotionCommand, m);
    worker.spinOnce(0);
    odometry_t o{};
    o.header.utime = clock2.now() - 8'000;
    if (i % 2 == 0) worker.publish(channels::kOdometry, o);
    clock2.advance(100'000);
    clock.advance(100'000);
  }
  worker.reportError("serial_crc", "frame 17: CRC mismatch");
  clock2.advance(10'000);
  worker.spinOnce(0);  // one period has passed: status goes out
  spin();
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->header.robot_id, 4);
  EXPECT_EQ(status->state, service_status_t::STATE_WARN);
  auto find = [&](const std::string& ch, int dir) {
    for (int i = 0; i < status->num_channels; ++i) {
      if (status->channel[i] == ch && status->direction[i] == dir) return i;
    }
    return -1;
  };
  const int in = find("MOTION_COMMAND", service_status_t::DIRECTION_IN);
  const int out = find("ODOMETRY", service_status_t::DIRECTION_OUT);
  ASSERT_GE(in, 0);
  ASSERT_GE(out, 0);
  EXPECT_EQ(status->messages_total[in], 10);
  EXPECT_EQ(status->messages_total[out], 5);
  EXPECT_NEAR(status->rate_hz[in], 10 / 1.01, 0.01);
  EXPECT_NEAR(status->latency_p50_ms[in], 30.0, 1e-3);  // the sender's latency
  EXPECT_NEAR(status->latency_p50_ms[out], 8.0, 1e-3);
  EXPECT_EQ(status->drops_total[in], 0);
  ASSERT_EQ(status->num_errors, 1);
  EXPECT_EQ(status->error_kind[0], "serial_crc");
  EXPECT_EQ(status->error_count[0], 1);
  EXPECT_EQ(status->last_error, "frame 17: CRC mismatch");
  ASSERT_EQ(status->num_metrics, 1);
  EXPECT_EQ(status->metric_name[0], "speed_mps");
  EXPECT_DOUBLE_EQ(status->metric_value[0], 1.25);
  EXPECT_GE(status->processing_max_ms, status->processing_p50_ms);
}

TEST(BusUrls, DefaultsFollowTheArchitecture) {
  EXPECT_EQ(robotBusUrl(1), "udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(robotBusUrl(6), "udpm://239.255.76.67:7673?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(simBusUrl(), "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(robotBusUrl(2, {.base_port = 9000}),
            "udpm://239.255.76.67:9002?ttl=0&recv_buf_size=4194304");
  EXPECT_THROW(robotBusUrl(0), std::invalid_argument);
}

TEST(BusUrls, LocalOnlyIsTheSameBusAtTtlZero) {
  EXPECT_EQ(localOnlyUrl(robotBusUrl(1, {.ttl = 1})),
            "udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(localOnlyUrl("udpm://239.255.76.67:7668?recv_buf_size=65536&ttl=32"),
            "udpm://239.255.76.67:7668?recv_buf_size=65536&ttl=0");
  EXPECT_EQ(localOnlyUrl("udpm://239.255.76.67:7668?recv_buf_size=65536"),
            "udpm://239.255.76.67:7668?recv_buf_size=65536&ttl=0");
  EXPECT_EQ(localOnlyUrl("udpm://239.255.76.67:7668"), "udpm://239.255.76.67:7668?ttl=0");
  EXPECT_EQ(localOnlyUrl("memq://"), "memq://");
}

TEST(BusErrors, BadProviderIsAClearError) {
  try {
    Connection::open("nosuchprovider://x");
    FAIL();
  } catch (const BusError& e) {
    EXPECT_NE(std::string(e.what()).find("nosuchprovider://x"), std::string::npos);
  }
}

}  // namespace node_test
}  // namespace fieldline::bus

namespace fieldline::bus {
namespace node_test {

TEST(BusRaw, SubscribeAllSeesEveryChannelAndItsHeader) {
  SimulatedClock clock{1'800'000'000'000'000};
  auto memq = Connection::open("memq://");
  Node sender{{.process = "s", .robot_id = 5, .status_period_us = 0}, clock, memq};
  Node watcher{{.process = "w", .robot_id = 5, .status_period_us = 0}, clock, memq};
  std::vector<std::pair<std::string, header_t>> seen;
  watcher.subscribeAllRaw([&](const std::string& channel, const void* data, int size) {
    const auto h = peekHeader(data, size);
    ASSERT_TRUE(h.has_value());
    seen.emplace_back(channel, *h);
  });
  odometry_t o{};
  o.header.utime = clock.now() - 8000;
  sender.publish(channels::kOdometry, o);
  image_t img{};
  img.header.utime = clock.now() - 60'000;
  img.width = 2;
  img.height = 1;
  img.stride = 4;
  img.size = 4;
  img.format = image_t::FORMAT_YUYV;
  img.data.assign(4, 7);
  sender.publish(channels::kCameraImage, img);
  for (int i = 0; i < 3; ++i)
    watcher.spinOnce(0);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].first, "ODOMETRY");
  EXPECT_EQ(seen[0].second.utime, o.header.utime);
  EXPECT_EQ(seen[0].second.utime_published, clock.now());
  EXPECT_EQ(seen[1].first, "CAMERA_IMAGE");
  EXPECT_EQ(seen[1].second.robot_id, 5);
  const std::uint8_t shortBytes[5] = {};
  EXPECT_FALSE(peekHeader(shortBytes, 5).has_value());
}

}  // namespace node_test
}  // namespace fieldline::bus

namespace fieldline::bus {
namespace node_test {

class HostileInput : public ::testing::Test {
 protected:
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<Connection> memq = Connection::open("memq://");
  Node sender{{.process = "s", .robot_id = 1, .status_period_us = 0}, clock, memq};
  Node receiver{{.process = "r", .robot_id = 1, .status_period_us = 0}, clock, memq};

  static std::vector<std::uint8_t> encode(const obstacle_observations_t& m) {
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(buf.data(), 0, static_cast<int>(buf.size()));
    return buf;
  }
  obstacle_observations_t two() {
    obstacle_observations_t m{};
    m.header.utime = clock.now();
    m.header.utime_published = clock.now();
    m.count = 2;
    m.bearing = {0.1f, 0.2f};
    m.distance = {1, 2};
    m.angular_width = {0.1f, 0.1f};
    m.width = {0.4f, 0.4f};
    m.x = {1, 2};
    m.y = {0, 0};
    return m;
  }
  // Offset of `count` in the encoding: fingerprint 8 + header 8+8+8+1+8 (publisher_id).
  static constexpr std::size_t kCountOffset = 8 + 33;
  static void setCount(std::vector<std::uint8_t>& buf, std::uint32_t count) {
    for (int i = 0; i < 4; ++i)
      buf[kCountOffset + i] = static_cast<std::uint8_t>(count >> (24 - 8 * i));
  }
};

TEST_F(HostileInput, AbsurdArrayCountsAreRejectedNotFatal) {
  int handled = 0;
  receiver.subscribe(channels::kVisionObstacles,
                     [&](const obstacle_observations_t&) { ++handled; });
  for (std::uint32_t count : {0xffffffffu, 0x7fffffffu, 0x20000000u, 3u}) {
    auto buf = encode(two());
    setCount(buf, count);
    sender.publishEncoded(channels::kVisionObstacles.name, buf.data(),
                          static_cast<int>(buf.size()));
  }
  for (int i = 0; i < 5; ++i)
    receiver.spinOnce(0);
  EXPECT_EQ(handled, 0);
  EXPECT_EQ(receiver.status().errorCount("decode"), 4);
}

TEST_F(HostileInput, EmptyArraysDoNotKeepThePreviousMessagesElements) {
  std::vector<std::size_t> sizes;
  receiver.subscribe(channels::kVisionObstacles,
                     [&](const obstacle_observations_t& m) { sizes.push_back(m.bearing.size()); });
  auto m = two();
  sender.publish(channels::kVisionObstacles, m);
  obstacle_observations_t none{};
  none.header.utime = clock.now();
  sender.publish(channels::kVisionObstacles, none);
  for (int i = 0; i < 5; ++i)
    receiver.spinOnce(0);
  EXPECT_EQ(sizes, (std::vector<std::size_t>{2, 0}));
}

TEST_F(HostileInput, CountAndArraySizeMustAgreeToPublish) {
  auto m = two();
  m.width.pop_back();
  EXPECT_FALSE(sender.publish(channels::kVisionObstacles, m));
  EXPECT_EQ(sender.status().errorCount("invalid_output"), 1);
  EXPECT_NE(sender.status().lastError().find("count = 2 but width has 1 elements"),
            std::string::npos)
      << sender.status().lastError();
}

TEST_F(HostileInput, RefusedPublishDoesNotUseASeqNumber) {
  std::vector<std::int64_t> seqs;
  receiver.subscribe(channels::kVisionObstacles,
                     [&](const obstacle_observations_t& m) { seqs.push_back(m.header.seq); });
  auto good = two();
  auto bad = two();
  bad.x[0] = std::numeric_limits<float>::quiet_NaN();
  sender.publish(channels::kVisionObstacles, good);
  EXPECT_FALSE(sender.publish(channels::kVisionObstacles, bad));
  sender.publish(channels::kVisionObstacles, good);
  for (int i = 0; i < 5; ++i)
    receiver.spinOnce(0);
  EXPECT_EQ(seqs, (std::vector<std::int64_t>{0, 1}));
  EXPECT_EQ(receiver.status().channel("VISION_OBSTACLES", Direction::kIn)->drops, 0);
}

TEST_F(HostileInput, HandlerExceptionIsCountedAndTheNodeGoesOn) {
  int calls = 0;
  receiver.subscribe(channels::kVisionObstacles, [&](const obstacle_observations_t&) {
    if (++calls == 1) throw std::runtime_error("boom");
  });
  auto m = two();
  sender.publish(channels::kVisionObstacles, m);
  sender.publish(channels::kVisionObstacles, m);
  for (int i = 0; i < 5; ++i)
    receiver.spinOnce(0);
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(receiver.status().errorCount("exception"), 1);
}

TEST_F(HostileInput, ANodeDestroyedBeforeItsSharedConnectionIsNotCalled) {
  int survivor_calls = 0;
  {
    Node shortLived{{.process = "short", .robot_id = 1, .status_period_us = 0}, clock, memq};
    shortLived.subscribe(channels::kVisionObstacles, [&](const obstacle_observations_t&) {});
  }
  receiver.subscribe(channels::kVisionObstacles,
                     [&](const obstacle_observations_t&) { ++survivor_calls; });
  auto m = two();
  sender.publish(channels::kVisionObstacles, m);
  for (int i = 0; i < 5; ++i)
    receiver.spinOnce(0);
  EXPECT_EQ(survivor_calls, 1);
}

TEST_F(HostileInput, SeveralStatusPublishersAreNotCountedAsDrops) {
  receiver.subscribe(channels::kServiceStatus, [&](const service_status_t&) {});
  Node a{{.process = "a", .robot_id = 1, .status_period_us = 0}, clock, memq};
  Node b{{.process = "b", .robot_id = 1, .status_period_us = 0}, clock, memq};
  for (int i = 0; i < 3; ++i) {
    a.publishStatus();
    a.publishStatus();
    b.publishStatus();
  }
  for (int i = 0; i < 5; ++i)
    receiver.spinOnce(0);
  EXPECT_EQ(receiver.status().channel("SERVICE_STATUS", Direction::kIn)->total, 9);
  EXPECT_EQ(receiver.status().channel("SERVICE_STATUS", Direction::kIn)->drops, 0);
}

}  // namespace node_test
}  // namespace fieldline::bus
