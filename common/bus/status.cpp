#include "common/bus/status.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include <unistd.h>

namespace fieldline::bus {

Percentiles percentiles(std::vector<float>& s) {
  Percentiles p;
  if (s.empty()) return p;
  auto at = [&](double q) {
    const auto k = static_cast<std::size_t>(std::floor(q * static_cast<double>(s.size() - 1)));
    std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(k), s.end());
    return s[k];
  };
  p.p50 = at(0.5);
  p.p95 = at(0.95);
  p.max = *std::max_element(s.begin(), s.end());
  return p;
}

StatusCollector::StatusCollector(std::string process, int robot_id, Utime start)
    : process_(std::move(process)), robot_id_(robot_id), start_(start), period_start_(start) {}

int StatusCollector::slot(std::string_view name, Direction d) {
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    if (channels_[i].name == name && channels_[i].direction == d) return static_cast<int>(i);
  }
  ChannelStats c;
  c.name = std::string(name);
  c.direction = d;
  channels_.push_back(std::move(c));
  return static_cast<int>(channels_.size() - 1);
}

const ChannelStats* StatusCollector::channel(const std::string& name, Direction d) const {
  for (const auto& c : channels_) {
    if (c.name == name && c.direction == d) return &c;
  }
  return nullptr;
}

void StatusCollector::onReceived(const std::string& channel, int sender, std::int64_t seq,
                                 Utime utime, Utime utime_published, bool track_drops) {
  Received m{.robot_id = sender, .seq = seq, .utime = utime, .utime_published = utime_published};
  ChannelStats& c = stats(channel, Direction::kIn);
  if (!track_drops) {
    ++c.total;
    ++c.in_period;
    c.last_message = utime_published;
    c.latency_ms.push_back(static_cast<float>(utime_published - utime) / 1000.0f);
    return;
  }
  onReceived(channel, m, utime_published, false);
}

namespace {
std::string publisherName(const PublisherTrack& p) {
  return fmt::format("robot {} publisher {:016x}", p.robot_id,
                     static_cast<std::uint64_t>(p.publisher_id));
}
std::string suspiciousText(const std::string& channel, const PublisherTrack& p,
                           const SeqOutcome& seq, std::int64_t got) {
  switch (seq.kind) {
    case SeqOutcome::Kind::kSuspiciousJump:
      return fmt::format(
          "{}: suspicious seq from {}: {} after {}, more than it can have sent since (a forged or "
          "corrupted seq); not counted as drops",
          channel, publisherName(p), got, seq.previous);
    case SeqOutcome::Kind::kDuplicate:
      return fmt::format("{}: suspicious seq from {}: {} twice (a forged copy?)", channel,
                         publisherName(p), got);
    default:
      return fmt::format(
          "{}: suspicious seq from {}: {} arrived after {}, so the {} messages counted lost "
          "before it were not (a forged or reordered seq); drops corrected",
          channel, publisherName(p), got, seq.previous, -seq.drops);
  }
}
}  // namespace

void StatusCollector::onReceived(const std::string& channel, const Received& m, Utime now,
                                 bool single_publisher) {
  onReceivedAt(slot(channel, Direction::kIn), m, now, single_publisher);
}

void StatusCollector::onReceivedAt(int slot, const Received& m, Utime now, bool single_publisher) {
  ChannelStats& c = channels_.at(static_cast<std::size_t>(slot));  // checked: public
  const std::string& channel = c.name;
  ++c.total;
  ++c.in_period;
  c.last_message = now;
  c.latency_ms.push_back(static_cast<float>(m.utime_published - m.utime) / 1000.0f);

  auto it = std::find_if(c.publishers.begin(), c.publishers.end(), [&](const PublisherTrack& p) {
    return p.robot_id == m.robot_id && p.publisher_id == m.publisher_id;
  });
  if (it == c.publishers.end()) {
    if (c.publishers.size() >= kMaxPublishersPerChannel) {
      // Bounded memory under a flood of forged ids: forget the longest silent one.
      auto oldest = std::min_element(c.publishers.begin(), c.publishers.end(),
                                     [](const PublisherTrack& a, const PublisherTrack& b) {
                                       return a.last_seen < b.last_seen;
                                     });
      c.publishers.erase(oldest);
    }
    c.publishers.push_back(PublisherTrack{m.robot_id, m.publisher_id, SeqTracker{}, now});
    it = c.publishers.end() - 1;
    it->seq.onMessage(m.seq, m.utime_published);
  } else {
    const SeqOutcome seq = it->seq.onMessage(m.seq, m.utime_published);
    c.drops += seq.drops;
    if (seq.kind == SeqOutcome::Kind::kResync) {
      ++c.resyncs;
      onError("seq_resync",
              fmt::format("{}: {}'s seq went on from {} after a jump; resynchronised, not counted "
                          "as drops",
                          channel, publisherName(*it), m.seq),
              now);
    } else if (seq.suspicious()) {
      ++c.suspicious;
      c.suspicious_seen = now;
      c.suspicious_text = suspiciousText(channel, *it, seq, m.seq);
      onError("seq_suspicious", c.suspicious_text, now);
    }
    it->last_seen = now;
  }

  auto previous = std::find_if(c.last_publisher_by_robot.begin(), c.last_publisher_by_robot.end(),
                               [&](const PublisherTrack& p) { return p.robot_id == m.robot_id; });
  if (previous == c.last_publisher_by_robot.end()) {
    c.last_publisher_by_robot.push_back(*it);
  } else {
    if (single_publisher && previous->publisher_id != it->publisher_id) {
      c.publisher_switches.push_back(now);
      std::erase_if(c.publisher_switches, [&](Utime t) { return t + kConflictWindowUs < now; });
      if (c.publisher_switches.size() >= kConflictSwitches) {
        const std::string text = fmt::format("{}: two publishers: {} and {}", channel,
                                             publisherName(*previous), publisherName(*it));
        if (c.conflict_seen < 0 || c.conflict_seen + kConflictWindowUs < now) {
          onError("two_publishers", text, now);
        }
        c.conflict_seen = now;
        c.conflict_text = text;
      }
    }
    *previous = *it;
  }
}

void StatusCollector::requireRate(const std::string& channel, Direction d, double min_rate_hz) {
  stats(channel, d).required_rate_hz = min_rate_hz;
}

void StatusCollector::onRejected(const std::string& channel) {
  ChannelStats& c = stats(channel, Direction::kIn);
  ++c.rejected;
}

void StatusCollector::onPublished(const std::string& channel, Utime utime, Utime utime_published) {
  onPublishedAt(slot(channel, Direction::kOut), utime, utime_published);
}

void StatusCollector::onPublishedAt(int slot, Utime utime, Utime utime_published) {
  ChannelStats& c = channels_.at(static_cast<std::size_t>(slot));  // checked: public
  ++c.total;
  ++c.in_period;
  c.latency_ms.push_back(static_cast<float>(utime_published - utime) / 1000.0f);
}

void StatusCollector::onProcessing(double ms) {
  processing_ms_.push_back(static_cast<float>(ms));
}

void StatusCollector::onError(const std::string& kind, const std::string& text, Utime when) {
  ++errors_[kind];
  ++errors_in_period_;
  last_error_ = text;
  last_error_utime_ = when;
}

void StatusCollector::setMetric(const std::string& name, double value) {
  metrics_[name] = value;
}

std::int64_t StatusCollector::errorCount(const std::string& kind) const {
  const auto it = errors_.find(kind);
  return it == errors_.end() ? 0 : it->second;
}

void StatusCollector::setWarning(const std::string& key, const std::string& reason) {
  if (reason.empty()) {
    warnings_.erase(key);
  } else {
    warnings_[key] = reason;
  }
}

namespace {

// A status period: from `start` to `end`, `seconds` long (at least 1 µs).
struct Period {
  Utime start = 0;
  Utime end = 0;
  double seconds = 0.0;
};

// Why the process is not ok this period: the error's reasons and the warning's, each a
// "; "-separated list.
struct StateReasons {
  std::string error;
  std::string warn;
};

void appendReason(std::string& to, const std::string& what) {
  if (!to.empty()) to += "; ";
  to += what;
}

// The warning for a channel below its required rate for longer than `grace_us`, or nothing;
// keeps `c.below_since` (reset when the rate is met). A channel that stays silent is named so
// from its last message (or the later of the process start and when it fell below).
std::optional<std::string> rateWarning(ChannelStats& c, const Period& period, Utime process_start,
                                       Utime grace_us) {
  const double rate = static_cast<double>(c.in_period) / period.seconds;
  if (rate >= c.required_rate_hz) {
    c.below_since = -1;
    return std::nullopt;
  }
  if (c.below_since < 0) c.below_since = period.start;
  const Utime below_us = period.end - c.below_since;
  if (below_us < grace_us) return std::nullopt;
  const Utime silent_since = std::max({c.last_message, process_start, c.below_since});
  if (c.in_period == 0) {
    return fmt::format("{} silent {:.1f} s", c.name,
                       static_cast<double>(period.end - silent_since) / 1e6);
  }
  return fmt::format("{} at {:.1f} Hz < {:.1f} Hz for {:.1f} s", c.name, rate, c.required_rate_hz,
                     static_cast<double>(below_us) / 1e6);
}

// A channel's reasons, in this order: a second publisher seen recently (an error), a recent
// suspicious seq and a required rate not met (warnings).
void addChannelReasons(StateReasons& reasons, ChannelStats& c, const Period& period,
                       Utime process_start, Utime grace_us) {
  const Utime now = period.end;
  if (c.conflict_seen >= 0 && c.conflict_seen + StatusCollector::kConflictWindowUs >= now) {
    appendReason(reasons.error, c.conflict_text);
  }
  if (c.suspicious_seen >= 0 && c.suspicious_seen + StatusCollector::kSuspiciousHoldUs >= now) {
    appendReason(reasons.warn, fmt::format("{} ({} suspicious seq since start)", c.suspicious_text,
                                           c.suspicious));
  }
  if (c.required_rate_hz <= 0) return;
  if (auto warning = rateWarning(c, period, process_start, grace_us)) {
    appendReason(reasons.warn, *warning);
  }
}

// ERROR (a fault, or an error reason) over WARN (a warning reason, or errors this period) over
// OK; without a reason of its own, the state gives the last error.
void setState(service_status_t& s, bool fault, const StateReasons& reasons, bool errors_in_period,
              const std::string& last_error) {
  if (fault || !reasons.error.empty()) {
    s.state = service_status_t::STATE_ERROR;
    s.state_reason = reasons.error.empty() ? last_error : reasons.error;
  } else if (!reasons.warn.empty() || errors_in_period) {
    s.state = service_status_t::STATE_WARN;
    s.state_reason = reasons.warn.empty() ? last_error : reasons.warn;
  } else {
    s.state = service_status_t::STATE_OK;
  }
}

// Each channel's counts, rate and latency percentiles of the period; starts its next period.
void addChannelFigures(service_status_t& s, std::vector<ChannelStats>& channels, double period_s) {
  s.num_channels = static_cast<std::int32_t>(channels.size());
  for (auto& c : channels) {
    const Percentiles p = percentiles(c.latency_ms);
    s.channel.push_back(c.name);
    s.direction.push_back(static_cast<std::int8_t>(c.direction));
    s.messages_total.push_back(c.total);
    s.rate_hz.push_back(static_cast<float>(static_cast<double>(c.in_period) / period_s));
    s.drops_total.push_back(c.drops);
    s.rejected_total.push_back(c.rejected);
    s.latency_p50_ms.push_back(p.p50);
    s.latency_p95_ms.push_back(p.p95);
    s.latency_max_ms.push_back(p.max);
    c.in_period = 0;
    c.latency_ms.clear();
  }
}

// The period's processing-time percentiles; forgets its samples.
void addProcessingTimes(service_status_t& s, std::vector<float>& processing_ms) {
  const Percentiles proc = percentiles(processing_ms);
  s.processing_p50_ms = proc.p50;
  s.processing_p95_ms = proc.p95;
  s.processing_max_ms = proc.max;
  processing_ms.clear();
}

// Error counts by kind since start, and the metrics (a non-finite one as 0).
void addErrorsAndMetrics(service_status_t& s, const std::map<std::string, std::int64_t>& errors,
                         const std::map<std::string, double>& metrics) {
  s.num_errors = static_cast<std::int32_t>(errors.size());
  for (const auto& [kind, count] : errors) {
    s.error_kind.push_back(kind);
    s.error_count.push_back(count);
  }
  s.num_metrics = static_cast<std::int32_t>(metrics.size());
  for (const auto& [name, value] : metrics) {
    s.metric_name.push_back(name);
    s.metric_value.push_back(std::isfinite(value) ? value : 0.0);
  }
}

}  // namespace

service_status_t StatusCollector::takeStatus(Utime now) {
  service_status_t s{};
  s.header.utime = now;
  s.header.robot_id = static_cast<std::int8_t>(robot_id_);
  s.process = process_;
  s.pid = static_cast<std::int32_t>(::getpid());
  s.uptime_us = now - start_;
  s.period_us = std::max<Utime>(1, now - period_start_);
  const Period period{period_start_, now, static_cast<double>(s.period_us) / 1e6};

  StateReasons reasons;
  for (auto& c : channels_)
    addChannelReasons(reasons, c, period, start_, rate_grace_us_);
  for (const auto& [key, reason] : warnings_)
    appendReason(reasons.warn, reason);
  setState(s, fault_, reasons, errors_in_period_ > 0, last_error_);

  addChannelFigures(s, channels_, period.seconds);
  addProcessingTimes(s, processing_ms_);
  addErrorsAndMetrics(s, errors_, metrics_);
  s.last_error = last_error_;
  s.last_error_utime = last_error_utime_;
  period_start_ = now;
  errors_in_period_ = 0;
  return s;
}

}  // namespace fieldline::bus
