// The accounting behind fieldline-bus-stats, without a bus (tested in tests/unit/health): each
// packet is checked against the fingerprint of the type its channel carries (the 8 bytes every
// LCM encoding starts with); a packet on an unknown channel, with another type's fingerprint or
// an undecodable header is counted as foreign, never as a message. Seq gaps are tracked per
// publisher and bounded; latencies outside a plausible window are counted, not averaged in.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/time/clock.hpp"

namespace fieldline::bus_stats {

// The fingerprint of the type carried by `channel` (channels.hpp), or nothing for an unknown one.
std::optional<std::int64_t> expectedFingerprint(const std::string& channel);

struct ChannelTraffic {
  std::int64_t count = 0;
  std::int64_t bytes = 0;
  // Packets on this channel name that are not a message of its type (wrong fingerprint,
  // undecodable header, or a channel fieldline does not have).
  std::int64_t foreign = 0;
  // Messages lost by seq gaps (single-publisher channels only).
  std::int64_t gaps = 0;
  // Seq jumps too large to be losses, counted once each.
  std::int64_t resyncs = 0;
  // Messages whose utime_published - utime is outside the plausible window.
  std::int64_t bad_stamps = 0;
  std::vector<float> latency_ms;
  Utime first = 0, last = 0;
  // Last seq per (robot_id, publisher_id).
  std::map<std::pair<int, std::int64_t>, std::int64_t> last_seq;
};

class TrafficCounter {
 public:
  static constexpr std::int64_t kMaxPlausibleGap = 1000;
  static constexpr Utime kMinLatencyUs = -kMicrosPerSecond;
  static constexpr Utime kMaxLatencyUs = 60 * kMicrosPerSecond;
  static constexpr std::size_t kMaxPublishers = 64;

  // One packet received on `bus` at receiver time `now`.
  void onPacket(const std::string& bus, const std::string& channel, const void* data, int size,
                Utime now);
  const std::map<std::pair<std::string, std::string>, ChannelTraffic>& traffic() const {
    return traffic_;
  }
  std::map<std::pair<std::string, std::string>, ChannelTraffic>& traffic() { return traffic_; }

 private:
  std::map<std::pair<std::string, std::string>, ChannelTraffic> traffic_;
};

}  // namespace fieldline::bus_stats
