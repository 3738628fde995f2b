// Issue 13, finding 5: fieldline-bus-stats counted foreign or garbage packets as messages and
// printed negative gaps and latencies of 1e14 ms.
#include <cstdint>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/channels.hpp"
#include "tools/bus_stats/traffic.hpp"

namespace fieldline::bus_stats {
namespace health_bus_stats_test {

constexpr Utime kNow = 1'800'000'000'000'000;

template <typename Msg>
std::vector<std::uint8_t> encode(const Msg& m) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

odometry_t odometry(std::int64_t seq, Utime utime, Utime published) {
  odometry_t o{};
  o.header.seq = seq;
  o.header.utime = utime;
  o.header.utime_published = published;
  o.header.robot_id = 1;
  o.header.publisher_id = 42;
  return o;
}

TEST(HealthBusStats, FingerprintsAreTheGeneratedTypes) {
  EXPECT_EQ(expectedFingerprint("ODOMETRY"), odometry_t::getHash());
  EXPECT_EQ(expectedFingerprint("CAMERA_IMAGE"), image_t::getHash());
  EXPECT_EQ(expectedFingerprint("CAMERA_PREVIEW"), image_t::getHash());
  EXPECT_EQ(expectedFingerprint("NOT_A_CHANNEL"), std::nullopt);
  // Every channel a bus carries is known (RECORDING_INFO is only ever in recordings).
  for (const std::string_view name : bus::kAllChannelNames) {
    if (name != bus::channels::kRecordingInfo.name) {
      EXPECT_TRUE(expectedFingerprint(std::string(name))) << name;
    }
  }
}

TEST(HealthBusStats, ForeignPacketsAreCountedApart) {
  TrafficCounter c;
  const auto good = encode(odometry(0, kNow - 8'000, kNow));
  c.onPacket("r1", "ODOMETRY", good.data(), static_cast<int>(good.size()), kNow);
  // Another type on the channel: a valid LCM message, but not odometry.
  robot_state_t rs{};
  rs.header.utime = kNow;
  rs.header.utime_published = kNow;
  const auto other = encode(rs);
  c.onPacket("r1", "ODOMETRY", other.data(), static_cast<int>(other.size()), kNow);
  // Garbage, too short, and a channel fieldline does not have.
  const std::vector<std::uint8_t> garbage(64, 0xab);
  c.onPacket("r1", "ODOMETRY", garbage.data(), static_cast<int>(garbage.size()), kNow);
  c.onPacket("r1", "ODOMETRY", garbage.data(), 3, kNow);
  c.onPacket("r1", "SOMEONE_ELSE", good.data(), static_cast<int>(good.size()), kNow);
  const ChannelTraffic& odo = c.traffic().at({"r1", "ODOMETRY"});
  EXPECT_EQ(odo.count, 1);
  EXPECT_EQ(odo.foreign, 3);
  EXPECT_EQ(c.traffic().at({"r1", "SOMEONE_ELSE"}).count, 0);
  EXPECT_EQ(c.traffic().at({"r1", "SOMEONE_ELSE"}).foreign, 1);
}

TEST(HealthBusStats, NoNegativeGapsNoAbsurdLatencies) {
  TrafficCounter c;
  auto send = [&](const odometry_t& o) {
    const auto b = encode(o);
    c.onPacket("r1", "ODOMETRY", b.data(), static_cast<int>(b.size()), kNow);
  };
  send(odometry(10, kNow - 8'000, kNow));
  send(odometry(5, kNow - 8'000, kNow));  // a step back: a restart, not -6 gaps
  send(odometry(6, kNow - 8'000, kNow));
  send(odometry(1'000'000'000'000'000, kNow - 8'000, kNow));  // forged jump
  send(odometry(7, kNow - 8'000, kNow));
  send(odometry(9, kNow - 8'000, kNow));  // one lost
  send(odometry(10, 1, std::numeric_limits<Utime>::max()));
  send(odometry(11, std::numeric_limits<Utime>::max(), 0));
  const ChannelTraffic& odo = c.traffic().at({"r1", "ODOMETRY"});
  EXPECT_EQ(odo.gaps, 1);
  EXPECT_EQ(odo.suspicious, 1);  // issue 34 finding 6: the forged jump (a resync before)
  EXPECT_EQ(odo.bad_stamps, 2);
  for (float ms : odo.latency_ms)
    EXPECT_FLOAT_EQ(ms, 8.0f);
}

}  // namespace health_bus_stats_test
}  // namespace fieldline::bus_stats
