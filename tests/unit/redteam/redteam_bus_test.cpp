// Issue 34, red-team findings 6, 7 and part of 10 (the bus layer and fieldline-bus-stats).
//
// Run against main at 6957b54 (before the fixes), each of these failed:
// - redteam_forged_drops (finding 6): 20 messages copying the real publisher's id with seq + 1000
//   raised the receiver's drops to 19,980 and its state stayed ok.
// - redteam_bus_stats_undecodable (finding 7): 300 packets with ODOMETRY's fingerprint and a body
//   that does not decode were counted as 300 messages (count 351 of 50 real ones and a NaN).
// - redteam_future_overflow (finding 10): a log stamp of INT64_MAX gave "utime ... is
//   -9221575747911036 ms in the future"; such an event is now refused as no time at all.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/checked_decode.hpp"
#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "tools/bus_stats/traffic.hpp"

namespace fieldline::bus {
namespace redteam_bus_test {

constexpr Utime kStart = 1'800'000'000'000'000;
constexpr Utime kPeriod = 20'000;  // ODOMETRY at 50 Hz

template <typename Msg>
std::vector<std::uint8_t> encode(const Msg& m) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

odometry_t odometry(std::int64_t seq, std::int64_t publisher, Utime published) {
  odometry_t o{};
  o.header.utime = published - 8'000;
  o.header.utime_published = published;
  o.header.seq = seq;
  o.header.robot_id = 1;
  o.header.publisher_id = publisher;
  return o;
}

class redteam_forged_drops : public ::testing::Test {
 protected:
  SimulatedClock clock{kStart};
  std::shared_ptr<Connection> memq = Connection::open("memq://");
  Node fusion{{.process = "fusion", .robot_id = 1, .status_period_us = 0}, clock, memq};
  Node motor_bridge{{.process = "motor_bridge", .robot_id = 1, .status_period_us = 0}, clock, memq};
  Node attacker{{.process = "attacker", .robot_id = 1, .status_period_us = 0}, clock, memq};

  void SetUp() override {
    fusion.subscribe(channels::kOdometry, [](const odometry_t&) {});
  }
  void spin() {
    for (int i = 0; i < 5; ++i)
      fusion.spinOnce(0);
  }
  // The real publisher's next message, 20 ms after the last.
  void real() {
    clock.advance(kPeriod);
    odometry_t o{};
    o.header.utime = clock.now() - 8'000;
    motor_bridge.publish(channels::kOdometry, o);
    spin();
  }
  // A forged copy of the real publisher's header with seq + `jump`, published `ahead` after now.
  void forged(std::int64_t last_real_seq, std::int64_t jump, Utime ahead = 0) {
    const auto bytes = encode(
        odometry(last_real_seq + jump, motor_bridge.publisherId(), clock.now() + 1'000 + ahead));
    attacker.publishEncoded(channels::kOdometry.name, bytes.data(), static_cast<int>(bytes.size()));
    spin();
  }
  const ChannelStats& odometryIn() { return *fusion.status().channel("ODOMETRY", Direction::kIn); }
};

// The red team's attack: 20 forged messages with seq + 1000, each right after a real one.
TEST_F(redteam_forged_drops, ForgedJumpsOfTheRealPublishersSeqAreSuspiciousNotDrops) {
  std::int64_t seq = 0;
  real();
  for (int k = 0; k < 20; ++k) {
    forged(seq, 1000);
    real();
    ++seq;
  }
  EXPECT_EQ(odometryIn().drops, 0);  // main: 19,980
  EXPECT_EQ(odometryIn().suspicious, 20);
  EXPECT_EQ(fusion.status().errorCount("seq_suspicious"), 20);
  const service_status_t s = fusion.status().takeStatus(clock.now());
  EXPECT_EQ(s.state, service_status_t::STATE_WARN);
  EXPECT_NE(s.state_reason.find("ODOMETRY: suspicious seq from robot 1 publisher"),
            std::string::npos)
      << s.state_reason;
  ASSERT_EQ(s.drops_total.size(), 1u);
  EXPECT_EQ(s.drops_total[0], 0);
}

// A forger who stamps its copies 0.49 s ahead makes a jump of 495 look possible; the real next
// message then arrives inside the gap, which proves it was none: the drops are taken back.
TEST_F(redteam_forged_drops, AGapThatTheRealPublisherFillsIsTakenBack) {
  std::int64_t seq = 0;
  real();
  for (int k = 0; k < 20; ++k) {
    forged(seq, 400, 490'000);
    real();
    ++seq;
  }
  EXPECT_EQ(odometryIn().drops, 0);
  EXPECT_EQ(odometryIn().suspicious, 20);
  EXPECT_EQ(fusion.status().takeStatus(clock.now()).state, service_status_t::STATE_WARN);
}

// What a real publisher loses still counts, and the warning ends 10 s after the last forgery.
TEST_F(redteam_forged_drops, RealLossesStillCountAndTheWarningEnds) {
  const std::int64_t id = 0x5eed;
  auto send = [&](std::int64_t seq, std::int64_t publisher) {
    const auto bytes = encode(odometry(seq, publisher, clock.now()));
    attacker.publishEncoded(channels::kOdometry.name, bytes.data(), static_cast<int>(bytes.size()));
    spin();
  };
  send(0, id);
  clock.advance(1'000);
  send(1000, id);  // forged
  EXPECT_EQ(fusion.status().takeStatus(clock.now()).state, service_status_t::STATE_WARN);
  for (std::int64_t seq = 1; seq < 600; ++seq) {
    clock.advance(kPeriod);
    if (seq % 100 == 50) continue;  // lost on the way: 6 of them
    send(seq, id);
  }
  EXPECT_EQ(odometryIn().drops, 6);
  EXPECT_EQ(odometryIn().suspicious, 1);
  const service_status_t s = fusion.status().takeStatus(clock.now());
  EXPECT_EQ(s.state, service_status_t::STATE_OK) << s.state_reason;
}

TEST(redteam_forged_drops_tracker, GapsOnlyAsLargeAsThePublishersTimeAllows) {
  SeqTracker t;
  t.onMessage(0, kStart);
  // 3 lost in 80 ms: plausible.
  EXPECT_EQ(t.onMessage(4, kStart + 4 * kPeriod).drops, 3);
  // 10 s of silence at 50 Hz: 499 lost.
  EXPECT_EQ(t.onMessage(504, kStart + 504 * kPeriod).drops, 499);
  // 1000 in 1 ms: no publisher does that.
  const SeqOutcome jump = t.onMessage(1505, kStart + 504 * kPeriod + 1'000);
  EXPECT_EQ(jump.kind, SeqOutcome::Kind::kSuspiciousJump);
  EXPECT_EQ(jump.drops, 0);
  // The real one goes on where it was.
  EXPECT_EQ(t.onMessage(505, kStart + 505 * kPeriod).kind, SeqOutcome::Kind::kInOrder);
  // A publisher that really moved on (a replayed log seeking ahead) is followed after one more.
  EXPECT_EQ(t.onMessage(9000, kStart + 506 * kPeriod).kind, SeqOutcome::Kind::kSuspiciousJump);
  EXPECT_EQ(t.onMessage(9001, kStart + 507 * kPeriod).kind, SeqOutcome::Kind::kResync);
  EXPECT_EQ(t.lastSeq(), 9001);
  // A restart without publisher id: back to 0, no drops.
  EXPECT_EQ(t.onMessage(0, kStart + 508 * kPeriod).kind, SeqOutcome::Kind::kRestart);
  EXPECT_EQ(t.onMessage(1, kStart + 509 * kPeriod).kind, SeqOutcome::Kind::kInOrder);
}

// Finding 7: a packet with the right fingerprint and a body that does not decode.
TEST(redteam_bus_stats_undecodable, RightFingerprintAndGarbageBodyIsUndecodableNotAMessage) {
  bus_stats::TrafficCounter c;
  Utime now = kStart;
  for (std::int64_t seq = 0; seq < 50; ++seq) {
    now += kPeriod;
    const auto good = encode(odometry(seq, 42, now));
    c.onPacket("r1", "ODOMETRY", good.data(), static_cast<int>(good.size()), now);
    // Six forged packets per real one (300 Hz of garbage on a 50 Hz channel): the fingerprint
    // and a plausible header copied, the rest cut off or overwritten.
    for (int k = 0; k < 6; ++k) {
      std::vector<std::uint8_t> bad = encode(odometry(seq, 42, now));
      if (k % 2 == 0) {
        bad.resize(bad.size() - 5);  // truncated body
      } else {
        bad.insert(bad.end(), 40, 0xab);  // bytes after the message
      }
      c.onPacket("r1", "ODOMETRY", bad.data(), static_cast<int>(bad.size()), now);
    }
  }
  // A NaN decodes but is no message either.
  odometry_t nan = odometry(50, 42, now + kPeriod);
  nan.dx = std::numeric_limits<double>::quiet_NaN();
  const auto nan_bytes = encode(nan);
  c.onPacket("r1", "ODOMETRY", nan_bytes.data(), static_cast<int>(nan_bytes.size()), now + kPeriod);
  const bus_stats::ChannelTraffic& odo = c.traffic().at({"r1", "ODOMETRY"});
  EXPECT_EQ(odo.count, 50);  // main: 351
  EXPECT_EQ(odo.undecodable, 300);
  EXPECT_EQ(odo.invalid, 1);
  EXPECT_EQ(odo.gaps, 0);
}

// Finding 10: stamps near INT64_MAX.
TEST(redteam_future_overflow, TheFutureCheckDoesNotOverflow) {
  header_t h{};
  h.utime = kStart;
  EXPECT_FALSE(checkNotFromFuture(h, std::numeric_limits<Utime>::max(), 500'000));
  EXPECT_FALSE(checkNotFromFuture(h, kStart, std::numeric_limits<Utime>::max()));
  h.utime = std::numeric_limits<Utime>::max();
  const auto r = checkNotFromFuture(h, kStart, 500'000);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->text.find("-"), std::string::npos) << r->text;
  EXPECT_NE(r->text.find("ms in the future"), std::string::npos) << r->text;
}

TEST(redteam_future_overflow, ALogEventStampedIntMaxIsRefusedAsNoTime) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "redteam_int64_stamp.lcmlog").string();
  {
    LogWriter w(path);
    const auto ok = encode(odometry(0, 7, kStart));
    w.write(channels::kOdometry.name, kStart, ok.data(), static_cast<int>(ok.size()));
    const auto late = encode(odometry(1, 7, kStart + kPeriod));
    w.write(channels::kOdometry.name, std::numeric_limits<Utime>::max(), late.data(),
            static_cast<int>(late.size()));
  }
  LogReader reader(path);
  odometry_t o{};
  int read = 0;
  while (reader.next(channels::kOdometry, o))
    ++read;
  EXPECT_EQ(read, 1);
  ASSERT_EQ(reader.rejectedByKind().count("bad_log_stamp"), 1u);
  EXPECT_EQ(reader.rejectedByKind().at("bad_log_stamp"), 1);
  std::filesystem::remove(path);
}

}  // namespace redteam_bus_test
}  // namespace fieldline::bus
