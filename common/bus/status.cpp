#include "common/bus/status.hpp"

#include <algorithm>
#include <cmath>

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

ChannelStats& StatusCollector::stats(const std::string& name, Direction d) {
  for (auto& c : channels_) {
    if (c.name == name && c.direction == d) return c;
  }
  ChannelStats c;
  c.name = name;
  c.direction = d;
  channels_.push_back(std::move(c));
  return channels_.back();
}

const ChannelStats* StatusCollector::channel(const std::string& name, Direction d) const {
  for (const auto& c : channels_) {
    if (c.name == name && c.direction == d) return &c;
  }
  return nullptr;
}

void StatusCollector::onReceived(const std::string& channel, int sender, std::int64_t seq,
                                 Utime utime, Utime utime_published, bool track_drops) {
  ChannelStats& c = stats(channel, Direction::kIn);
  ++c.total;
  ++c.in_period;
  auto [it, fresh] = c.last_seq_by_sender.try_emplace(sender, seq);
  if (!fresh && track_drops) {
    // A gap means lost messages; a step back means the sender restarted (not a loss).
    if (seq > it->second + 1) c.drops += seq - it->second - 1;
    it->second = seq;
  }
  c.latency_ms.push_back(static_cast<float>(utime_published - utime) / 1000.0f);
}

void StatusCollector::onRejected(const std::string& channel) {
  ChannelStats& c = stats(channel, Direction::kIn);
  ++c.rejected;
}

void StatusCollector::onPublished(const std::string& channel, Utime utime, Utime utime_published) {
  ChannelStats& c = stats(channel, Direction::kOut);
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

service_status_t StatusCollector::takeStatus(Utime now) {
  service_status_t s{};
  s.header.utime = now;
  s.header.robot_id = static_cast<std::int8_t>(robot_id_);
  s.process = process_;
  s.pid = static_cast<std::int32_t>(::getpid());
  s.uptime_us = now - start_;
  s.period_us = std::max<Utime>(1, now - period_start_);
  s.state = fault_                  ? service_status_t::STATE_ERROR
            : errors_in_period_ > 0 ? service_status_t::STATE_WARN
                                    : service_status_t::STATE_OK;
  const double period_s = static_cast<double>(s.period_us) / 1e6;

  s.num_channels = static_cast<std::int32_t>(channels_.size());
  for (auto& c : channels_) {
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
  const Percentiles proc = percentiles(processing_ms_);
  s.processing_p50_ms = proc.p50;
  s.processing_p95_ms = proc.p95;
  s.processing_max_ms = proc.max;
  processing_ms_.clear();

  s.num_errors = static_cast<std::int32_t>(errors_.size());
  for (const auto& [kind, count] : errors_) {
    s.error_kind.push_back(kind);
    s.error_count.push_back(count);
  }
  s.last_error = last_error_;
  s.last_error_utime = last_error_utime_;

  s.num_metrics = static_cast<std::int32_t>(metrics_.size());
  for (const auto& [name, value] : metrics_) {
    s.metric_name.push_back(name);
    s.metric_value.push_back(std::isfinite(value) ? value : 0.0);
  }
  period_start_ = now;
  errors_in_period_ = 0;
  return s;
}

}  // namespace fieldline::bus
