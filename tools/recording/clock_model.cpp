#include "tools/recording/clock_model.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/bus/checked_decode.hpp"
#include "common/bus/log_file.hpp"

namespace fieldline::recording {

const char* toString(ClockSource source) {
  switch (source) {
    case ClockSource::kNone:
      return "none";
    case ClockSource::kRecorded:
      return "recorded";
    case ClockSource::kEstimated:
      return "estimated";
    case ClockSource::kGiven:
      return "given";
  }
  return "?";
}

std::string RobotClockModel::describe() const {
  std::string text = fmt::format("offset {:+.1f} ms, drift {:+.1f} ppm ({}", error.offset_us * 1e-3,
                                 error.drift_ppm, toString(source));
  if (source == ClockSource::kEstimated) {
    text += fmt::format(" from {} messages, delivery delay p50 {:.1f} ms, p99 {:.1f} ms", samples,
                        delay_p50_ms, delay_p99_ms);
  }
  return text + ")";
}

namespace {

double quantile(std::vector<double>& values, double q) {
  const auto k = static_cast<std::size_t>(
      std::clamp(q * static_cast<double>(values.size() - 1), 0.0, double(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

std::optional<RobotClockModel> fitClock(std::vector<StampSample> samples,
                                        const ClockFitOptions& options) {
  if (samples.empty()) return std::nullopt;
  std::sort(samples.begin(), samples.end(),
            [](const StampSample& a, const StampSample& b) { return a.log_time < b.log_time; });
  const Utime reference = samples.front().log_time;
  const auto window_us = static_cast<Utime>(options.window_s * 1e6);
  // Per window: its middle (s since the reference) and the envelope of published - log (µs).
  std::vector<std::pair<double, double>> envelope;
  std::vector<double> d;
  for (std::size_t begin = 0; begin < samples.size();) {
    const Utime window_end = samples[begin].log_time + window_us;
    std::size_t end = begin;
    d.clear();
    while (end < samples.size() && samples[end].log_time < window_end) {
      d.push_back(static_cast<double>(samples[end].published - samples[end].log_time));
      ++end;
    }
    if (static_cast<int>(d.size()) >= options.min_window_samples) {
      const double middle =
          0.5 * static_cast<double>(samples[begin].log_time + samples[end - 1].log_time) -
          static_cast<double>(reference);
      envelope.emplace_back(middle * 1e-6, quantile(d, options.envelope_quantile));
    }
    begin = end;
  }
  if (envelope.empty()) return std::nullopt;

  RobotClockModel model;
  model.source = ClockSource::kEstimated;
  model.error.reference_us = reference;
  const double span_s = envelope.back().first - envelope.front().first;
  double offset = 0.0;
  double slope = 0.0;  // µs per s = ppm
  if (envelope.size() >= 3 && span_s >= options.min_drift_span_s) {
    double st = 0, sv = 0, stt = 0, stv = 0;
    for (const auto& [t, v] : envelope) {
      st += t;
      sv += v;
      stt += t * t;
      stv += t * v;
    }
    const double n = static_cast<double>(envelope.size());
    slope = (n * stv - st * sv) / (n * stt - st * st);
    offset = (sv - slope * st) / n;
    slope = std::clamp(slope, -kMaxClockDriftPpm, kMaxClockDriftPpm);
  } else {
    std::vector<double> values;
    for (const auto& e : envelope)
      values.push_back(e.second);
    offset = quantile(values, 0.5);
  }
  model.error.offset_us = static_cast<Utime>(std::llround(offset));
  model.error.drift_ppm = slope;
  // How far below the fitted clock the messages were: their delivery delay.
  std::vector<double> delays;
  delays.reserve(samples.size());
  for (const StampSample& s : samples)
    delays.push_back(static_cast<double>(model.ownAt(s.log_time) - s.published) * 1e-3);
  model.samples = static_cast<std::int64_t>(samples.size());
  model.delay_p50_ms = quantile(delays, 0.5);
  model.delay_p99_ms = quantile(delays, 0.99);
  return model;
}

std::optional<header_t> peekHeader(const void* data, int size) {
  header_t header;
  // Every fieldline message is its 8-byte fingerprint and then header_t (lcmtypes/: header first).
  if (data == nullptr || size <= 8 || header._decodeNoHash(data, 8, size - 8) < 0) return {};
  return header;
}

std::map<int, RobotClockModel> estimateClocks(const std::string& path,
                                              const ClockFitOptions& options) {
  bus::LogReader log(path);
  bus::LogEvent event;
  std::map<int, std::vector<StampSample>> by_robot;
  while (log.nextEvent(event)) {
    const auto fingerprint =
        bus::detail::fingerprintOf(event.data.data(), static_cast<int>(event.data.size()));
    // Only messages of the project's types have a header where peekHeader looks.
    if (!fingerprint || bus::detail::typeWithFingerprint(*fingerprint).empty()) continue;
    const auto header = peekHeader(event.data.data(), static_cast<int>(event.data.size()));
    if (!header || header->robot_id < 0 || header->robot_id > 6) continue;
    by_robot[header->robot_id].push_back({event.timestamp, header->utime_published});
  }
  std::map<int, RobotClockModel> models;
  for (auto& [robot, samples] : by_robot) {
    if (auto model = fitClock(std::move(samples), options)) {
      model->robot_id = robot;
      models.emplace(robot, *model);
    }
  }
  return models;
}

}  // namespace fieldline::recording
