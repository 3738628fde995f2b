// Per-process traffic and health statistics behind SERVICE_STATUS: counts and rates per channel,
// drops from seq gaps, latency and processing-time percentiles, error counters, metrics.
// Plain C++ (the Node feeds it), so it is tested without a bus.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <fieldline/service_status_t.hpp>

#include "common/time/clock.hpp"

namespace fieldline::bus {

enum class Direction : std::int8_t { kIn = 0, kOut = 1 };

struct ChannelStats {
  std::string name;
  Direction direction = Direction::kIn;
  std::int64_t total = 0;
  std::int64_t in_period = 0;
  std::int64_t drops = 0;
  std::int64_t rejected = 0;
  std::vector<float> latency_ms;  // this period's samples
  std::map<int, std::int64_t> last_seq_by_sender;
};

struct Percentiles {
  float p50 = 0, p95 = 0, max = 0;
};
// Percentiles of `samples` (reorders them). Zeros when empty.
Percentiles percentiles(std::vector<float>& samples);

class StatusCollector {
 public:
  StatusCollector(std::string process, int robot_id, Utime start);

  // A received message: counts it, tracks seq gaps per sender, records the sender's latency.
  // `track_drops` is false on channels with several publishers per robot (SERVICE_STATUS).
  void onReceived(const std::string& channel, int sender, std::int64_t seq, Utime utime,
                  Utime utime_published, bool track_drops = true);
  // A message that was received but not handled (undecodable, invalid, from the future).
  void onRejected(const std::string& channel);
  // A published message.
  void onPublished(const std::string& channel, Utime utime, Utime utime_published);
  void onProcessing(double ms);
  void onError(const std::string& kind, const std::string& text, Utime when);
  void setMetric(const std::string& name, double value);
  // While set, the process reports STATE_ERROR: it cannot do its job (a device is missing).
  void setFault(bool fault) { fault_ = fault; }
  bool fault() const { return fault_; }

  // Fills a status message for the period ending at `now` and starts a new period.
  service_status_t takeStatus(Utime now);

  const ChannelStats* channel(const std::string& name, Direction d) const;
  std::int64_t errorCount(const std::string& kind) const;
  const std::string& lastError() const { return last_error_; }

 private:
  ChannelStats& stats(const std::string& name, Direction d);

  std::string process_;
  int robot_id_;
  Utime start_;
  Utime period_start_;
  std::vector<ChannelStats> channels_;
  std::vector<float> processing_ms_;
  std::map<std::string, std::int64_t> errors_;
  std::string last_error_;
  Utime last_error_utime_ = 0;
  std::map<std::string, double> metrics_;
  std::int64_t errors_in_period_ = 0;
  bool fault_ = false;
};

}  // namespace fieldline::bus
