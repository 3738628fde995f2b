// The team packet: what one robot tells its teammates, in a versioned little-endian binary format
// authenticated with a keyed MAC (libsodium crypto_auth, HMAC-SHA-512-256). Field by field, with
// units and ranges: docs/team-protocol.md. Plain library: no LCM, no clock.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "teamcomm/team_key.hpp"

namespace fieldline::teamcomm {

// Version 2: the pose's status byte carries the twin flag (bit 7), which version 1 refused.
inline constexpr std::uint8_t kProtocolVersion = 2;
inline constexpr int kMaxRobots = 6;
inline constexpr int kMaxObstacles = 10;
inline constexpr std::size_t kMaxPacketBytes = 1400;
inline constexpr std::size_t kMacBytes = 32;

// Ranges every decoded value must lie in (documented in docs/team-protocol.md).
inline constexpr double kMaxFieldCoordinate_m = 30.0;
inline constexpr double kMaxSpeed_mps = 20.0;
inline constexpr double kMaxAngularSpeed_radps = 50.0;
inline constexpr double kMaxVariance = 1.0e4;  // m^2, m*rad or rad^2
inline constexpr double kMaxObstacleRadius_m = 2.0;

// For one teammate: the sender time of the last packet we received from it and our receive
// time of that packet (each on its own clock); the teammate turns this into a round trip.
struct LinkEcho {
  std::uint8_t robot_id = 0;  // 1..6
  std::int64_t their_send_utime = 0;
  std::int64_t our_receive_utime = 0;
};

struct PacketPose {
  std::int64_t utime = 0;           // sender's clock, µs
  float x = 0, y = 0, phi = 0;      // field frame, m, rad in [-pi, pi]
  float vx = 0, vy = 0, omega = 0;  // m/s, rad/s
  // Upper triangle of the (x, y, phi) covariance: xx, xy, xphi, yy, yphi, phiphi.
  std::array<float, 6> covariance{};
  std::uint8_t status = 0;  // perception::LocalizationStatus, 0..3
  // The pose may be its field-symmetric twin (RobotEstimate::twin_ambiguous): the sender's
  // field-frame ball is then no better (bit 7 of the status byte on the wire).
  bool twin_ambiguous = false;
  std::int64_t since_vision_us = 0;
};

struct PacketBall {
  std::int64_t utime = 0;             // sender's clock, µs
  std::int64_t last_seen_utime = 0;   // sender's clock, µs
  float x = 0, y = 0;                 // field frame, m
  float vx = 0, vy = 0;               // m/s
  std::array<float, 3> covariance{};  // xx, xy, yy, m^2
};

struct PacketObstacle {
  float x = 0, y = 0;  // field frame, m
  float radius = 0;    // m
};

struct TeamPacket {
  std::uint8_t team_id = 0;   // 0..255
  std::uint8_t robot_id = 0;  // 1..6
  // Starts at the sender's clock in µs at start-up and counts up by one per packet, so it keeps
  // increasing across restarts of the sender.
  std::uint64_t sequence = 0;
  std::int64_t send_utime = 0;  // sender's clock, µs
  std::vector<LinkEcho> links;  // at most kMaxRobots, distinct robot ids
  std::optional<PacketPose> pose;
  std::optional<PacketBall> ball;
  std::vector<PacketObstacle> obstacles;  // at most kMaxObstacles
};

// Why a packet was refused; names appear in SERVICE_STATUS as "rejected_<name>".
enum class Reject : std::uint8_t {
  kTruncated,  // shorter than the smallest valid packet
  kOversized,  // longer than kMaxPacketBytes
  kMagic,      // not a fieldline team packet
  kVersion,    // another protocol version
  kAuth,       // MAC does not match (wrong key, corrupted, forged)
  kLength,     // counts disagree with the length
  kRange,      // a value outside its documented range (or not finite)
  kTeam,       // another team's packet
  kReplay,     // sequence number already seen from this sender (or too old to tell)
  kLate,       // older than the newest accepted from this sender, not seen before: reordered
  kStale,      // send time too old (or too far in the future) for our clock
  kRate,       // sender above its rate limit
};
inline constexpr int kRejectKinds = 12;
std::string_view rejectName(Reject r);

struct DecodeResult {
  std::optional<TeamPacket> packet;
  Reject reason = Reject::kTruncated;  // meaningful when !packet
};

// Serialises and signs. Throws std::invalid_argument when `p` is out of range (a caller bug: the
// node clamps before).
std::vector<std::uint8_t> encodePacket(const TeamPacket& p, const TeamKey& key);
// Checks size, magic, version, MAC, then layout and ranges; never throws.
DecodeResult decodePacket(std::span<const std::uint8_t> bytes, const TeamKey& key);
// The encoded size of a packet with these counts.
std::size_t packetSize(std::size_t links, bool pose, bool ball, std::size_t obstacles);

}  // namespace fieldline::teamcomm
