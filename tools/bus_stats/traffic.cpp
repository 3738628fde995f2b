#include "tools/bus_stats/traffic.hpp"

#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"
#include "common/bus/node.hpp"

namespace fieldline::bus_stats {
namespace {

template <typename Msg>
bool matches(const std::string& channel, bus::Channel<Msg> c, std::optional<std::int64_t>& out) {
  if (channel != c.name) return false;
  out = Msg::getHash();
  return true;
}

std::int64_t readFingerprint(const void* data) {
  // LCM writes the fingerprint big-endian.
  const auto* b = static_cast<const std::uint8_t*>(data);
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i)
    v = (v << 8) | b[i];
  return static_cast<std::int64_t>(v);
}

}  // namespace

std::optional<std::int64_t> expectedFingerprint(const std::string& channel) {
  namespace ch = bus::channels;
  std::optional<std::int64_t> f;
  matches(channel, ch::kCameraImage, f) || matches(channel, ch::kVisionLines, f) ||
      matches(channel, ch::kVisionBall, f) || matches(channel, ch::kVisionObstacles, f) ||
      matches(channel, ch::kFieldFeatures, f) || matches(channel, ch::kOdometry, f) ||
      matches(channel, ch::kMotionCommand, f) || matches(channel, ch::kRobotState, f) ||
      matches(channel, ch::kBallState, f) || matches(channel, ch::kTeamState, f) ||
      matches(channel, ch::kServiceStatus, f) || matches(channel, ch::kSimWorld, f) ||
      matches(channel, ch::kCameraPreview, f);
  return f;
}

void TrafficCounter::onPacket(const std::string& bus, const std::string& channel, const void* data,
                              int size, Utime now) {
  ChannelTraffic& t = traffic_[{bus, channel}];
  const auto expected = expectedFingerprint(channel);
  const auto header = bus::peekHeader(data, size);
  if (!expected || size < 8 || readFingerprint(data) != *expected || !header || header->seq < 0) {
    ++t.foreign;
    return;
  }
  if (const auto rejection = bus::checkDecodes(channel, data, size)) {
    ++(rejection->kind == "invalid" ? t.invalid : t.undecodable);
    return;
  }
  if (t.count == 0) t.first = now;
  t.last = now;
  ++t.count;
  t.bytes += size;

  // Every process publishes SERVICE_STATUS with its own seq: gaps there mean nothing.
  if (channel != bus::channels::kServiceStatus.name) {
    const std::pair<int, std::int64_t> publisher{header->robot_id, header->publisher_id};
    auto it = t.last_seq.find(publisher);
    if (it == t.last_seq.end()) {
      if (t.last_seq.size() >= kMaxPublishers) t.last_seq.erase(t.last_seq.begin());
      t.last_seq[publisher].onMessage(header->seq, header->utime_published);
    } else {
      const bus::SeqOutcome seq = it->second.onMessage(header->seq, header->utime_published);
      t.gaps += seq.drops;
      if (seq.kind == bus::SeqOutcome::Kind::kResync) ++t.resyncs;
      if (seq.suspicious()) ++t.suspicious;
    }
  }
  // In long double: the difference of two untrusted int64 stamps can overflow.
  const long double latency_us =
      static_cast<long double>(header->utime_published) - static_cast<long double>(header->utime);
  if (latency_us < kMinLatencyUs || latency_us > kMaxLatencyUs) {
    ++t.bad_stamps;
    return;
  }
  t.latency_ms.push_back(static_cast<float>(latency_us / 1000.0L));
}

}  // namespace fieldline::bus_stats
