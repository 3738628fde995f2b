#include "teamcomm/packet.hpp"

#include <sodium.h>

#include <bit>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace fieldline::teamcomm {
namespace {

constexpr std::array<std::uint8_t, 4> kMagic{'F', 'L', 'T', 'M'};
constexpr std::size_t kHeaderBytes = 26;
constexpr std::size_t kLinkBytes = 17;
constexpr std::size_t kPoseBytes = 65;
constexpr std::size_t kBallBytes = 44;
constexpr std::size_t kObstacleBytes = 12;
constexpr std::uint8_t kFlagPose = 1;
constexpr std::uint8_t kFlagBall = 2;
// In the pose's status byte: the twin flag; bits 2..6 stay 0 (status is 0..3).
constexpr unsigned kStatusTwinBit = 0x80;
// Times are µs since the epoch: beyond 2^62 µs (146,000 years) nothing is plausible.
constexpr std::int64_t kMaxUtime = std::int64_t{1} << 62;

static_assert(crypto_auth_BYTES == kMacBytes);
static_assert(crypto_auth_KEYBYTES == 32);

class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>& out) : out_(out) {}
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i)
      out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void f32(float v) {
    const auto bits = std::bit_cast<std::uint32_t>(v);
    for (int i = 0; i < 4; ++i)
      out_.push_back(static_cast<std::uint8_t>(bits >> (8 * i)));
  }

 private:
  std::vector<std::uint8_t>& out_;
};

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> in) : in_(in) {}
  std::uint8_t u8() { return in_[pos_++]; }
  std::uint64_t u64() {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i)
      v |= std::uint64_t{in_[pos_++]} << (8 * i);
    return v;
  }
  std::int64_t i64() { return static_cast<std::int64_t>(u64()); }
  float f32() {
    std::uint32_t bits = 0;
    for (int i = 0; i < 4; ++i)
      bits |= std::uint32_t{in_[pos_++]} << (8 * i);
    return std::bit_cast<float>(bits);
  }

 private:
  std::span<const std::uint8_t> in_;
  std::size_t pos_ = 0;
};

bool within(float v, double limit) {
  return std::isfinite(v) && std::fabs(v) <= limit;
}
bool utimeOk(std::int64_t t) {
  return t >= 0 && t < kMaxUtime;
}
bool varianceOk(float v) {
  return std::isfinite(v) && v >= 0.0f && v <= kMaxVariance;
}
bool robotOk(std::uint8_t id) {
  return id >= 1 && id <= kMaxRobots;
}

bool poseOk(const PacketPose& p) {
  const auto& c = p.covariance;
  return utimeOk(p.utime) && within(p.x, kMaxFieldCoordinate_m) &&
         within(p.y, kMaxFieldCoordinate_m) && within(p.phi, std::numbers::pi + 1e-6) &&
         within(p.vx, kMaxSpeed_mps) && within(p.vy, kMaxSpeed_mps) &&
         within(p.omega, kMaxAngularSpeed_radps) && varianceOk(c[0]) && varianceOk(c[3]) &&
         varianceOk(c[5]) && within(c[1], kMaxVariance) && within(c[2], kMaxVariance) &&
         within(c[4], kMaxVariance) && p.status <= 3 && utimeOk(p.since_vision_us);
}

bool ballOk(const PacketBall& b) {
  return utimeOk(b.utime) && utimeOk(b.last_seen_utime) && within(b.x, kMaxFieldCoordinate_m) &&
         within(b.y, kMaxFieldCoordinate_m) && within(b.vx, kMaxSpeed_mps) &&
         within(b.vy, kMaxSpeed_mps) && varianceOk(b.covariance[0]) &&
         varianceOk(b.covariance[2]) && within(b.covariance[1], kMaxVariance);
}

bool obstacleOk(const PacketObstacle& o) {
  return within(o.x, kMaxFieldCoordinate_m) && within(o.y, kMaxFieldCoordinate_m) &&
         std::isfinite(o.radius) && o.radius >= 0.0f && o.radius <= kMaxObstacleRadius_m;
}

bool rangesOk(const TeamPacket& p) {
  if (!robotOk(p.robot_id) || !utimeOk(p.send_utime)) return false;
  if (p.links.size() > static_cast<std::size_t>(kMaxRobots)) return false;
  if (p.obstacles.size() > static_cast<std::size_t>(kMaxObstacles)) return false;
  unsigned seen = 0;
  for (const LinkEcho& l : p.links) {
    if (!robotOk(l.robot_id) || l.robot_id == p.robot_id) return false;
    if (seen & (1u << l.robot_id)) return false;
    seen |= 1u << l.robot_id;
    if (!utimeOk(l.their_send_utime) || !utimeOk(l.our_receive_utime)) return false;
  }
  if (p.pose && !poseOk(*p.pose)) return false;
  if (p.ball && !ballOk(*p.ball)) return false;
  for (const PacketObstacle& o : p.obstacles) {
    if (!obstacleOk(o)) return false;
  }
  return true;
}

void initSodium() {
  // Idempotent and thread-safe; fails only when no entropy source exists.
  static const bool ok = sodium_init() >= 0;
  if (!ok) throw std::runtime_error("libsodium failed to initialise");
}

}  // namespace

std::string_view rejectName(Reject r) {
  switch (r) {
    case Reject::kTruncated:
      return "truncated";
    case Reject::kOversized:
      return "oversized";
    case Reject::kMagic:
      return "magic";
    case Reject::kVersion:
      return "version";
    case Reject::kAuth:
      return "auth";
    case Reject::kLength:
      return "length";
    case Reject::kRange:
      return "range";
    case Reject::kTeam:
      return "team";
    case Reject::kReplay:
      return "replay";
    case Reject::kLate:
      return "late";
    case Reject::kStale:
      return "stale";
    case Reject::kRate:
      return "rate";
  }
  return "unknown";
}

std::size_t packetSize(std::size_t links, bool pose, bool ball, std::size_t obstacles) {
  return kHeaderBytes + links * kLinkBytes + (pose ? kPoseBytes : 0) + (ball ? kBallBytes : 0) +
         obstacles * kObstacleBytes + kMacBytes;
}

std::vector<std::uint8_t> encodePacket(const TeamPacket& p, const TeamKey& key) {
  if (!rangesOk(p)) throw std::invalid_argument("team packet out of range");
  initSodium();
  std::vector<std::uint8_t> out;
  out.reserve(
      packetSize(p.links.size(), p.pose.has_value(), p.ball.has_value(), p.obstacles.size()));
  Writer w(out);
  for (std::uint8_t m : kMagic)
    w.u8(m);
  w.u8(kProtocolVersion);
  w.u8(p.team_id);
  w.u8(p.robot_id);
  w.u8(static_cast<std::uint8_t>((p.pose ? kFlagPose : 0) | (p.ball ? kFlagBall : 0)));
  w.u8(static_cast<std::uint8_t>(p.links.size()));
  w.u8(static_cast<std::uint8_t>(p.obstacles.size()));
  w.u64(p.sequence);
  w.i64(p.send_utime);
  for (const LinkEcho& l : p.links) {
    w.u8(l.robot_id);
    w.i64(l.their_send_utime);
    w.i64(l.our_receive_utime);
  }
  if (p.pose) {
    const PacketPose& q = *p.pose;
    w.i64(q.utime);
    for (float v : {q.x, q.y, q.phi, q.vx, q.vy, q.omega})
      w.f32(v);
    for (float v : q.covariance)
      w.f32(v);
    w.u8(static_cast<std::uint8_t>(q.status | (q.twin_ambiguous ? kStatusTwinBit : 0u)));
    w.i64(q.since_vision_us);
  }
  if (p.ball) {
    const PacketBall& b = *p.ball;
    w.i64(b.utime);
    w.i64(b.last_seen_utime);
    for (float v : {b.x, b.y, b.vx, b.vy})
      w.f32(v);
    for (float v : b.covariance)
      w.f32(v);
  }
  for (const PacketObstacle& o : p.obstacles) {
    for (float v : {o.x, o.y, o.radius})
      w.f32(v);
  }
  const std::size_t body = out.size();
  out.resize(body + kMacBytes);
  crypto_auth(out.data() + body, out.data(), body, key.bytes.data());
  return out;
}

DecodeResult decodePacket(std::span<const std::uint8_t> bytes, const TeamKey& key) {
  auto fail = [](Reject r) { return DecodeResult{std::nullopt, r}; };
  const std::size_t minimum = packetSize(0, false, false, 0);
  if (bytes.size() > kMaxPacketBytes) return fail(Reject::kOversized);
  if (bytes.size() < minimum) return fail(Reject::kTruncated);
  for (std::size_t i = 0; i < kMagic.size(); ++i) {
    if (bytes[i] != kMagic[i]) return fail(Reject::kMagic);
  }
  if (bytes[4] != kProtocolVersion) return fail(Reject::kVersion);
  try {
    initSodium();
  } catch (const std::exception&) {
    return fail(Reject::kAuth);
  }
  // The MAC is checked before any other byte is trusted.
  const std::size_t body = bytes.size() - kMacBytes;
  if (crypto_auth_verify(bytes.data() + body, bytes.data(), body, key.bytes.data()) != 0) {
    return fail(Reject::kAuth);
  }
  const std::uint8_t flags = bytes[7];
  const std::size_t links = bytes[8];
  const std::size_t obstacles = bytes[9];
  if ((flags & ~(kFlagPose | kFlagBall)) != 0 || links > static_cast<std::size_t>(kMaxRobots) ||
      obstacles > static_cast<std::size_t>(kMaxObstacles)) {
    return fail(Reject::kRange);
  }
  if (bytes.size() != packetSize(links, flags & kFlagPose, flags & kFlagBall, obstacles)) {
    return fail(Reject::kLength);
  }
  Reader r(bytes);
  TeamPacket p;
  for (int i = 0; i < 5; ++i)
    r.u8();  // magic and version, checked above
  p.team_id = r.u8();
  p.robot_id = r.u8();
  r.u8();  // flags
  r.u8();  // link count
  r.u8();  // obstacle count
  p.sequence = r.u64();
  p.send_utime = r.i64();
  p.links.resize(links);
  for (LinkEcho& l : p.links) {
    l.robot_id = r.u8();
    l.their_send_utime = r.i64();
    l.our_receive_utime = r.i64();
  }
  if (flags & kFlagPose) {
    PacketPose& q = p.pose.emplace();
    q.utime = r.i64();
    for (float* v : {&q.x, &q.y, &q.phi, &q.vx, &q.vy, &q.omega})
      *v = r.f32();
    for (float& v : q.covariance)
      v = r.f32();
    const std::uint8_t status = r.u8();
    q.status = status & static_cast<std::uint8_t>(~kStatusTwinBit);
    q.twin_ambiguous = (status & kStatusTwinBit) != 0;
    q.since_vision_us = r.i64();
  }
  if (flags & kFlagBall) {
    PacketBall& b = p.ball.emplace();
    b.utime = r.i64();
    b.last_seen_utime = r.i64();
    for (float* v : {&b.x, &b.y, &b.vx, &b.vy})
      *v = r.f32();
    for (float& v : b.covariance)
      v = r.f32();
  }
  p.obstacles.resize(obstacles);
  for (PacketObstacle& o : p.obstacles) {
    for (float* v : {&o.x, &o.y, &o.radius})
      *v = r.f32();
  }
  if (!rangesOk(p)) return fail(Reject::kRange);
  return {std::move(p), Reject::kTruncated};
}

}  // namespace fieldline::teamcomm
