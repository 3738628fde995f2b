// The team packet codec: every field survives a round trip at its range limits; every
// truncation, every single-bit flip, random bytes and a wrong key are rejected; out-of-range
// values are refused on both sides. The gate: replays, old packets and floods are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <sodium.h>

#include "teamcomm/packet.hpp"
#include "teamcomm/packet_gate.hpp"
#include "teamcomm/team_key.hpp"

namespace fieldline::teamcomm {
namespace packet_test {

TeamKey testKey(std::uint8_t seed) {
  TeamKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i)
    k.bytes[i] = static_cast<std::uint8_t>(seed + 7 * i);
  return k;
}

// A packet with every optional part present and every value at a limit of its range.
TeamPacket fullPacket(bool upper) {
  const float s = upper ? 1.0f : -1.0f;
  TeamPacket p;
  p.team_id = upper ? 255 : 0;
  p.robot_id = upper ? 6 : 1;
  p.sequence = upper ? std::numeric_limits<std::uint64_t>::max() : 0;
  p.send_utime = upper ? (std::int64_t{1} << 62) - 1 : 0;
  for (std::uint8_t id = 1; id <= kMaxRobots; ++id) {
    if (id == p.robot_id) continue;
    p.links.push_back({id, upper ? (std::int64_t{1} << 62) - 1 : 0, 1'700'000'000'000'000 + id});
  }
  PacketPose& q = p.pose.emplace();
  q.utime = 1'700'000'000'123'456;
  q.x = s * 30.0f;
  q.y = -s * 30.0f;
  q.phi = s * static_cast<float>(std::numbers::pi);
  q.vx = s * 20.0f;
  q.vy = -s * 20.0f;
  q.omega = s * 50.0f;
  q.covariance = {upper ? 1e4f : 0.0f, s * 1e4f, -s * 1e4f,
                  upper ? 1e4f : 0.0f, s * 1e4f, upper ? 1e4f : 0.0f};
  q.status = upper ? 3 : 0;
  q.twin_ambiguous = upper;
  q.since_vision_us = upper ? (std::int64_t{1} << 62) - 1 : 0;
  PacketBall& b = p.ball.emplace();
  b.utime = upper ? (std::int64_t{1} << 62) - 1 : 0;
  b.last_seen_utime = 1'700'000'000'000'001;
  b.x = -s * 30.0f;
  b.y = s * 30.0f;
  b.vx = s * 20.0f;
  b.vy = -s * 20.0f;
  b.covariance = {upper ? 1e4f : 0.0f, -s * 1e4f, upper ? 1e4f : 0.0f};
  for (int i = 0; i < kMaxObstacles; ++i) {
    p.obstacles.push_back({s * 30.0f, -s * (30.0f - static_cast<float>(i)), upper ? 2.0f : 0.0f});
  }
  return p;
}

void expectSame(const TeamPacket& a, const TeamPacket& b) {
  EXPECT_EQ(a.team_id, b.team_id);
  EXPECT_EQ(a.robot_id, b.robot_id);
  EXPECT_EQ(a.sequence, b.sequence);
  EXPECT_EQ(a.send_utime, b.send_utime);
  ASSERT_EQ(a.links.size(), b.links.size());
  for (std::size_t i = 0; i < a.links.size(); ++i) {
    EXPECT_EQ(a.links[i].robot_id, b.links[i].robot_id);
    EXPECT_EQ(a.links[i].their_send_utime, b.links[i].their_send_utime);
    EXPECT_EQ(a.links[i].our_receive_utime, b.links[i].our_receive_utime);
  }
  ASSERT_EQ(a.pose.has_value(), b.pose.has_value());
  if (a.pose) {
    const PacketPose &x = *a.pose, &y = *b.pose;
    EXPECT_EQ(x.utime, y.utime);
    EXPECT_EQ(x.x, y.x);
    EXPECT_EQ(x.y, y.y);
    EXPECT_EQ(x.phi, y.phi);
    EXPECT_EQ(x.vx, y.vx);
    EXPECT_EQ(x.vy, y.vy);
    EXPECT_EQ(x.omega, y.omega);
    EXPECT_EQ(x.covariance, y.covariance);
    EXPECT_EQ(x.status, y.status);
    EXPECT_EQ(x.twin_ambiguous, y.twin_ambiguous);
    EXPECT_EQ(x.since_vision_us, y.since_vision_us);
  }
  ASSERT_EQ(a.ball.has_value(), b.ball.has_value());
  if (a.ball) {
    const PacketBall &x = *a.ball, &y = *b.ball;
    EXPECT_EQ(x.utime, y.utime);
    EXPECT_EQ(x.last_seen_utime, y.last_seen_utime);
    EXPECT_EQ(x.x, y.x);
    EXPECT_EQ(x.y, y.y);
    EXPECT_EQ(x.vx, y.vx);
    EXPECT_EQ(x.vy, y.vy);
    EXPECT_EQ(x.covariance, y.covariance);
  }
  ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
  for (std::size_t i = 0; i < a.obstacles.size(); ++i) {
    EXPECT_EQ(a.obstacles[i].x, b.obstacles[i].x);
    EXPECT_EQ(a.obstacles[i].y, b.obstacles[i].y);
    EXPECT_EQ(a.obstacles[i].radius, b.obstacles[i].radius);
  }
}

TEST(teamcomm_codec, RoundTripsEveryFieldAtBothEndsOfItsRange) {
  const TeamKey key = testKey(1);
  for (bool upper : {false, true}) {
    const TeamPacket p = fullPacket(upper);
    const auto bytes = encodePacket(p, key);
    EXPECT_LE(bytes.size(), kMaxPacketBytes);
    EXPECT_EQ(bytes.size(), packetSize(5, true, true, 10));
    const DecodeResult r = decodePacket(bytes, key);
    ASSERT_TRUE(r.packet) << rejectName(r.reason);
    expectSame(p, *r.packet);
  }
}

TEST(teamcomm_codec, RoundTripsTheSmallestPacket) {
  TeamPacket p;
  p.robot_id = 3;
  p.sequence = 42;
  p.send_utime = 1'700'000'000'000'000;
  const TeamKey key = testKey(2);
  const auto bytes = encodePacket(p, key);
  EXPECT_EQ(bytes.size(), packetSize(0, false, false, 0));
  const DecodeResult r = decodePacket(bytes, key);
  ASSERT_TRUE(r.packet);
  expectSame(p, *r.packet);
}

TEST(teamcomm_codec, RefusesToEncodeOutOfRangeValues) {
  const TeamKey key = testKey(3);
  auto refuses = [&](auto mutate) {
    TeamPacket p = fullPacket(true);
    mutate(p);
    EXPECT_THROW(encodePacket(p, key), std::invalid_argument);
  };
  refuses([](TeamPacket& p) { p.robot_id = 0; });
  refuses([](TeamPacket& p) { p.robot_id = 7; });
  refuses([](TeamPacket& p) { p.send_utime = -1; });
  refuses([](TeamPacket& p) { p.pose->x = 30.01f; });
  refuses([](TeamPacket& p) { p.pose->y = std::numeric_limits<float>::quiet_NaN(); });
  refuses([](TeamPacket& p) { p.pose->phi = 3.2f; });
  refuses([](TeamPacket& p) { p.pose->vx = std::numeric_limits<float>::infinity(); });
  refuses([](TeamPacket& p) { p.pose->covariance[0] = -1.0f; });
  refuses([](TeamPacket& p) { p.pose->status = 4; });
  refuses([](TeamPacket& p) { p.ball->covariance[2] = 1.1e4f; });
  refuses([](TeamPacket& p) { p.ball->vy = -20.5f; });
  refuses([](TeamPacket& p) { p.obstacles.push_back({0, 0, 0.2f}); });
  refuses([](TeamPacket& p) { p.obstacles[0].radius = 2.5f; });
  refuses([](TeamPacket& p) { p.links.push_back({p.links[0]}); });  // 6 links, duplicate id
  refuses([](TeamPacket& p) { p.links[1].robot_id = p.links[0].robot_id; });
  refuses([](TeamPacket& p) { p.links[0].robot_id = p.robot_id; });  // echo of itself
}

TEST(teamcomm_codec, RejectsEveryTruncation) {
  const TeamKey key = testKey(4);
  const auto bytes = encodePacket(fullPacket(true), key);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const DecodeResult r = decodePacket(std::span(bytes.data(), n), key);
    EXPECT_FALSE(r.packet) << "accepted a packet cut to " << n << " bytes";
  }
}

TEST(teamcomm_codec, RejectsEverySingleBitFlip) {
  const TeamKey key = testKey(5);
  for (bool upper : {false, true}) {
    auto bytes = encodePacket(fullPacket(upper), key);
    for (std::size_t bit = 0; bit < bytes.size() * 8; ++bit) {
      bytes[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      const DecodeResult r = decodePacket(bytes, key);
      EXPECT_FALSE(r.packet) << "accepted a flip of bit " << bit;
      // Beyond the magic and version, only the MAC can tell.
      if (bit >= 40) {
        EXPECT_EQ(r.reason, Reject::kAuth);
      }
      bytes[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
    EXPECT_TRUE(decodePacket(bytes, key).packet);
  }
}

TEST(teamcomm_codec, RejectsAWrongKeyAndRandomBytes) {
  const auto bytes = encodePacket(fullPacket(false), testKey(6));
  const DecodeResult wrong = decodePacket(bytes, testKey(7));
  EXPECT_FALSE(wrong.packet);
  EXPECT_EQ(wrong.reason, Reject::kAuth);

  std::mt19937 rng(11);
  const TeamKey key = testKey(6);
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::uint8_t> junk(std::uniform_int_distribution<std::size_t>(0, 1500)(rng));
    for (auto& b : junk)
      b = static_cast<std::uint8_t>(rng());
    // Half of them with a valid magic and version, so the MAC is what stops them.
    if (i % 2 == 0 && junk.size() >= 5) {
      junk[0] = 'F';
      junk[1] = 'L';
      junk[2] = 'T';
      junk[3] = 'M';
      junk[4] = kProtocolVersion;
    }
    EXPECT_FALSE(decodePacket(junk, key).packet);
  }
}

TEST(teamcomm_codec, NamesTheReasonForSizeMagicAndVersion) {
  const TeamKey key = testKey(8);
  auto bytes = encodePacket(fullPacket(false), key);
  std::vector<std::uint8_t> big(kMaxPacketBytes + 1, 0);
  EXPECT_EQ(decodePacket(big, key).reason, Reject::kOversized);
  EXPECT_EQ(decodePacket(std::span(bytes.data(), 10), key).reason, Reject::kTruncated);
  auto other = bytes;
  other[0] = 'X';
  EXPECT_EQ(decodePacket(other, key).reason, Reject::kMagic);
  other = bytes;
  other[4] = kProtocolVersion + 1;
  EXPECT_EQ(decodePacket(other, key).reason, Reject::kVersion);
}

// The pose's status byte: 26 header bytes, 17 per link, then the pose's utime (8) and 12 f32.
std::size_t statusOffset(std::size_t links) {
  return 26 + 17 * links + 8 + 12 * 4;
}

// Signs `bytes` again after a test changed them (as a sender with the team key would).
void sign(std::vector<std::uint8_t>& bytes, const TeamKey& key) {
  const std::size_t body = bytes.size() - kMacBytes;
  crypto_auth(bytes.data() + body, bytes.data(), body, key.bytes.data());
}

TEST(teamcomm_codec, CarriesTheTwinFlagInBitSevenOfTheStatusByte) {
  const TeamKey key = testKey(9);
  TeamPacket p = fullPacket(false);
  p.pose->status = 2;  // tracking
  for (const bool twin : {false, true}) {
    p.pose->twin_ambiguous = twin;
    const auto bytes = encodePacket(p, key);
    EXPECT_EQ(bytes[statusOffset(p.links.size())], twin ? 0x82 : 0x02);
    const DecodeResult r = decodePacket(bytes, key);
    ASSERT_TRUE(r.packet) << rejectName(r.reason);
    EXPECT_EQ(r.packet->pose->status, 2);
    EXPECT_EQ(r.packet->pose->twin_ambiguous, twin);
  }
}

TEST(teamcomm_codec, RefusesReservedStatusBitsAndTheFirstVersion) {
  const TeamKey key = testKey(10);
  const TeamPacket p = fullPacket(false);
  const auto good = encodePacket(p, key);
  // Bits 2..6 of the status byte are reserved: a signed packet using one is out of range.
  for (const std::uint8_t status : {0x04, 0x40, 0xC2, 0xFF}) {
    auto bytes = good;
    bytes[statusOffset(p.links.size())] = status;
    sign(bytes, key);
    EXPECT_EQ(decodePacket(bytes, key).reason, Reject::kRange) << int{status};
  }
  // Version 1 had no twin flag (and refused bit 7): a robot still sending it is named as such.
  auto old = good;
  old[4] = 1;
  sign(old, key);
  EXPECT_EQ(decodePacket(old, key).reason, Reject::kVersion);
}

TEST(teamcomm_key, ParsesWhatItFormatsAndNamesTheLineOfAnError) {
  const TeamKey key = generateTeamKey();
  const std::string text = formatTeamKey(key, "test key\nsecond line");
  EXPECT_EQ(parseTeamKey(text, "k").bytes, key.bytes);
  EXPECT_NE(generateTeamKey().bytes, key.bytes);
  try {
    parseTeamKey("# comment\n\nabc\n", "team.key");
    FAIL() << "short key accepted";
  } catch (const KeyError& e) {
    EXPECT_NE(std::string(e.what()).find("team.key:3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parseTeamKey(std::string(63, 'a') + "g\n", "k"), KeyError);
  EXPECT_THROW(parseTeamKey("# only a comment\n", "k"), KeyError);
  EXPECT_THROW(parseTeamKey(std::string(64, 'a') + "\n" + std::string(64, 'b') + "\n", "k"),
               KeyError);
  EXPECT_THROW(loadTeamKey("/nonexistent/team.key"), KeyError);
}

// The gate, on authenticated packets.
TeamPacket gatePacket(std::uint8_t robot, std::uint64_t seq, Utime send) {
  TeamPacket p;
  p.team_id = 9;
  p.robot_id = robot;
  p.sequence = seq;
  p.send_utime = send;
  return p;
}

constexpr Utime kT0 = 1'700'000'000'000'000;

TEST(teamcomm_gate, RefusesReplaysOldPacketsAndOtherTeams) {
  PacketGate gate({.team_id = 9});
  EXPECT_EQ(gate.admit(gatePacket(2, 100, kT0), kT0 + 3000, 0.0), std::nullopt);
  EXPECT_EQ(gate.admit(gatePacket(2, 100, kT0), kT0 + 4000, 0.0), Reject::kReplay);
  // 99 was never seen: overtaken on the way (late), and a copy of it afterwards is a replay.
  EXPECT_EQ(gate.admit(gatePacket(2, 99, kT0 + 10'000), kT0 + 14'000, 0.0), Reject::kLate);
  EXPECT_EQ(gate.admit(gatePacket(2, 99, kT0 + 10'000), kT0 + 15'000, 0.0), Reject::kReplay);
  // Too far back to tell: a replay.
  EXPECT_EQ(gate.admit(gatePacket(2, 30, kT0 + 10'000), kT0 + 15'000, 0.0), Reject::kReplay);
  EXPECT_EQ(gate.admit(gatePacket(2, 101, kT0 + 50'000), kT0 + 52'000, 0.0), std::nullopt);
  // A recording of a later packet replayed 2 s later: too old once the offset is known.
  EXPECT_EQ(gate.admit(gatePacket(2, 150, kT0 + 60'000), kT0 + 2'060'000, 0.0), Reject::kStale);
  // From the future.
  EXPECT_EQ(gate.admit(gatePacket(2, 151, kT0 + 400'000), kT0 + 100'000, 0.0), Reject::kStale);
  // With an offset of +0.3 s, a packet stamped 0.3 s ahead of us is fresh.
  EXPECT_EQ(gate.admit(gatePacket(2, 152, kT0 + 400'000), kT0 + 101'000, 300'000.0), std::nullopt);
  EXPECT_EQ(gate.admit(gatePacket(3, 1, kT0), kT0 + 1000, std::nullopt), std::nullopt);
  // No offset yet: only a gross clock difference is refused.
  EXPECT_EQ(gate.admit(gatePacket(4, 1, kT0 + 11'000'000), kT0, std::nullopt), Reject::kStale);
  TeamPacket other = gatePacket(5, 1, kT0);
  other.team_id = 10;
  EXPECT_EQ(gate.admit(other, kT0 + 1000, std::nullopt), Reject::kTeam);
  EXPECT_EQ(gate.lost(2), 50);  // 101 -> 152, only 152 admitted after 101
}

TEST(teamcomm_gate, LimitsEachSendersRateWithoutStarvingOthers) {
  PacketGate gate({.team_id = 9, .rate_limit_hz = 40.0, .burst = 10.0});
  int admitted = 0, limited = 0;
  // A flood of 1000 packets within 100 ms from robot 2.
  for (int i = 0; i < 1000; ++i) {
    const Utime t = kT0 + i * 100;
    const auto r = gate.admit(gatePacket(2, 1000 + i, t), t + 500, 0.0);
    if (!r) ++admitted;
    if (r == Reject::kRate) ++limited;
  }
  EXPECT_EQ(admitted + limited, 1000);
  EXPECT_LE(admitted, 10 + 4 + 1);  // the burst plus 40 Hz over 0.1 s
  EXPECT_GE(admitted, 10);
  // Robot 3 at 20 Hz meanwhile is untouched.
  for (int i = 0; i < 20; ++i) {
    const Utime t = kT0 + i * 50'000;
    EXPECT_EQ(gate.admit(gatePacket(3, 1 + i, t), t + 500, 0.0), std::nullopt);
  }
  // And robot 2 at a normal rate is admitted again after the flood.
  const Utime later = kT0 + 1'000'000;
  EXPECT_EQ(gate.admit(gatePacket(2, 5000, later), later + 500, 0.0), std::nullopt);
}

}  // namespace packet_test
}  // namespace fieldline::teamcomm
