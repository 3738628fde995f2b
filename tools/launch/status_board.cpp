#include "tools/launch/status_board.hpp"

#include <cmath>
#include <limits>

#include <algorithm>

#include <fmt/format.h>

#include "common/bus/channels.hpp"

namespace fieldline::launch {
namespace {

// Control characters (newlines, escapes) would break the table and the terminal.
std::string printable(const std::string& text) {
  std::string out = text;
  std::replace_if(
      out.begin(), out.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; }, ' ');
  return out;
}

std::string number(const std::optional<double>& value) {
  if (!value) return "-";
  return *value < 1.0 ? fmt::format("{:.2f}", *value) : fmt::format("{:.1f}", *value);
}

const char* colourOf(Severity s) {
  switch (s) {
    case Severity::kGood:
      return "\x1b[32m";
    case Severity::kNotice:
      return "\x1b[33m";
    case Severity::kBad:
      return "\x1b[31;1m";
    case Severity::kIdle:
      return "\x1b[2m";
  }
  return "";
}

// Values beyond these are not measurements (a forged or broken report): shown as "-" and flagged.
constexpr double kMaxPlausibleRateHz = 10'000.0;
constexpr double kMinPlausibleLatencyMs = -1'000.0;
constexpr double kMaxPlausibleLatencyMs = 60'000.0;
constexpr double kMaxPlausibleProcessingMs = 60'000.0;

// `value` if it lies in [lo, hi], else nothing and a note of what was dropped in `untrusted`.
std::optional<double> trusted(double value, double lo, double hi, const char* what,
                              std::string& untrusted) {
  if (std::isfinite(value) && value >= lo && value <= hi) return value;
  if (!untrusted.empty()) untrusted += ", ";
  untrusted += fmt::format("{} {:.3g}", what, value);
  return std::nullopt;
}

void fillFromReport(const service_status_t& s, const std::string& preferred, StatusRow& row) {
  if (const auto i = mainOutputChannel(s, preferred)) {
    row.channel = printable(s.channel[*i]);
    row.rate_hz = trusted(s.rate_hz[*i], 0.0, kMaxPlausibleRateHz, "rate_hz", row.untrusted);
    if (*i < s.latency_p50_ms.size()) {
      row.latency_p50_ms = trusted(s.latency_p50_ms[*i], kMinPlausibleLatencyMs,
                                   kMaxPlausibleLatencyMs, "latency_p50_ms", row.untrusted);
    }
    if (*i < s.latency_p95_ms.size()) {
      row.latency_p95_ms = trusted(s.latency_p95_ms[*i], kMinPlausibleLatencyMs,
                                   kMaxPlausibleLatencyMs, "latency_p95_ms", row.untrusted);
    }
  }
  row.processing_p95_ms = trusted(s.processing_p95_ms, 0.0, kMaxPlausibleProcessingMs,
                                  "processing_p95_ms", row.untrusted);
  const std::size_t channels = std::min(s.direction.size(), s.drops_total.size());
  for (std::size_t i = 0; i < channels; ++i) {
    if (s.direction[i] != service_status_t::DIRECTION_IN) continue;
    if (s.drops_total[i] < 0 || s.drops_total[i] > std::numeric_limits<std::int64_t>::max() / 2) {
      trusted(static_cast<double>(s.drops_total[i]), 0.0, 0.0, "drops", row.untrusted);
      continue;
    }
    row.drops += s.drops_total[i];
  }
  for (std::int64_t count : s.error_count) {
    if (count < 0 || count > std::numeric_limits<std::int64_t>::max() / 2) {
      trusted(static_cast<double>(count), 0.0, 0.0, "error_count", row.untrusted);
      continue;
    }
    row.errors += count;
  }
  if (!s.state_reason.empty()) {
    row.last_error = printable(s.state_reason);
  } else if (!s.last_error.empty()) {
    row.last_error = printable(s.last_error);
  }
  row.note = headlineMetrics(s);
  if (!row.untrusted.empty()) row.last_error = "untrusted report: " + row.untrusted;
}

}  // namespace

void StatusBoard::onStatus(int bus_robot, const service_status_t& status,
                           SteadyClock::time_point now) {
  ++reports_;
  latest_[{bus_robot, status.pid}] = Report{status, now};
  // Forget processes that stopped reporting long ago (earlier runs of restarted processes).
  std::erase_if(latest_, [&](const auto& entry) {
    return secondsBetween(entry.second.received, now) > 10 * kStaleAfterS;
  });
}

const StatusBoard::Report* StatusBoard::find(const ProcessRecord& record) const {
  if (record.pid <= 0) return nullptr;
  if (auto it = latest_.find({record.instance.robot, record.pid}); it != latest_.end()) {
    return &it->second;
  }
  // A wrapper (a script that starts the real program) reports another pid: match by name.
  const Report* best = nullptr;
  for (const auto& [key, report] : latest_) {
    if (key.first != record.instance.robot || report.status.process != record.instance.name) {
      continue;
    }
    if (report.received < record.started) continue;
    if (best == nullptr || report.received > best->received) best = &report;
  }
  return best;
}

std::vector<StatusRow> StatusBoard::rows(const std::vector<ProcessRecord>& processes, bool stopping,
                                         SteadyClock::time_point now) const {
  std::vector<StatusRow> out;
  out.reserve(processes.size());
  for (const ProcessRecord& p : processes) {
    StatusRow row;
    row.robot = robotLabel(p.instance.robot);
    row.process = p.instance.name;
    row.restarts = p.restarts;
    row.last_error = printable(p.last_error);
    switch (p.state) {
      case ProcessState::kMissing:
        row.state = "missing";
        row.last_error = p.instance.executable + " is not built";
        break;
      case ProcessState::kWaiting:
        row.state = "waiting";
        row.severity = Severity::kBad;
        break;
      case ProcessState::kExited:
        row.state = "exited";
        break;
      case ProcessState::kFailed:
        row.state = "failed";
        row.severity = Severity::kBad;
        break;
      case ProcessState::kStopped:
        row.state = "stopped";
        break;
      case ProcessState::kRunning: {
        const Report* report = find(p);
        if (report != nullptr) fillFromReport(report->status, p.instance.main_channel, row);
        if (stopping) {
          row.state = "stopping";
          row.severity = Severity::kNotice;
        } else if (report == nullptr) {
          const bool young = secondsBetween(p.started, now) < kStaleAfterS;
          row.state = young ? "starting" : "running";
          row.severity = Severity::kNotice;
        } else if (secondsBetween(report->received, now) > kStaleAfterS) {
          row.state = "stale";
          row.severity = Severity::kNotice;
        } else if (!row.untrusted.empty()) {
          // A report with impossible numbers is not an "ok" (nor anything else it claims).
          row.state = "suspect";
          row.severity = Severity::kNotice;
        } else if (report->status.state == service_status_t::STATE_OK) {
          row.state = "ok";
          row.severity = Severity::kGood;
        } else if (report->status.state == service_status_t::STATE_WARN) {
          row.state = "warn";
          row.severity = Severity::kNotice;
        } else {
          row.state = "error";
          row.severity = Severity::kBad;
        }
        break;
      }
    }
    out.push_back(std::move(row));
  }
  return out;
}

std::string headlineMetrics(const service_status_t& status) {
  // Metric name, label, unit, digits: the first ones a process reports make its note.
  struct Headline {
    const char* metric;
    const char* label;
    const char* unit;
    int digits;
  };
  static constexpr Headline kHeadlines[] = {
      {"speed_mps", "speed", "m/s", 2},
      {"reference_speed_mps", "ref", "m/s", 2},
      {"render_ms", "render", "ms", 2},
      {"capture_ms", "capture", "ms", 2},
      {"touched_percent", "touched", "%", 1},
      {"realtime_factor", "realtime x", "", 2},
      {"correction_cm", "corr", "cm", 1},
      {"correction_deg", "turn", "deg", 1},
      // teamcomm: teammates heard, worst clock offset uncertainty, refused packets.
      {"teammates_present", "team", "", 0},
      {"offset_uncertainty_ms", "offset +-", "ms", 2},
      {"packets_rejected", "rejected", "", 0},
      // feature_recognition: features per second by kind.
      {"circles_per_s", "circles", "/s", 1},
      {"corners_per_s", "corners", "/s", 1},
      {"other_features_per_s", "other", "/s", 1},
  };
  std::string note;
  const std::size_t n = std::min(status.metric_name.size(), status.metric_value.size());
  // Fusion: the localization status by name first (robot_state_t's STATUS_ values).
  for (std::size_t i = 0; i < n; ++i) {
    if (status.metric_name[i] != "localization_status") continue;
    static constexpr const char* kNames[] = {"UNKNOWN", "SEARCHING", "TRACKING", "ODOMETRY_ONLY"};
    const int v = static_cast<int>(status.metric_value[i]);
    note += v >= 0 && v <= 3 ? kNames[v] : "?";
  }
  // A pilot without a scenario sends nothing on purpose.
  for (std::size_t i = 0; i < n; ++i) {
    if (status.metric_name[i] == "holding" && status.metric_value[i] > 0.5) note += "holding still";
  }
  // ... and whether the pose may be its symmetric twin (nothing told them apart yet).
  for (std::size_t i = 0; i < n; ++i) {
    if (status.metric_name[i] == "ambiguous" && status.metric_value[i] > 0.5 && !note.empty())
      note += " (twin?)";
  }
  for (const Headline& h : kHeadlines) {
    for (std::size_t i = 0; i < n; ++i) {
      if (status.metric_name[i] != h.metric) continue;
      if (!note.empty()) note += ", ";
      note += fmt::format("{} {:.{}f}{}{}", h.label, status.metric_value[i], h.digits,
                          *h.unit ? " " : "", h.unit);
    }
  }
  return note;
}

std::optional<std::size_t> mainOutputChannel(const service_status_t& status,
                                             const std::string& preferred) {
  const std::size_t n =
      std::min({status.channel.size(), status.direction.size(), status.rate_hz.size()});
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < n; ++i) {
    if (status.direction[i] != service_status_t::DIRECTION_OUT) continue;
    if (!preferred.empty()) {
      if (status.channel[i] == preferred) return i;
      continue;
    }
    if (status.channel[i] == bus::channels::kServiceStatus.name) continue;
    if (!best || status.rate_hz[i] > status.rate_hz[*best]) best = i;
  }
  return best;
}

std::vector<std::string> renderTable(const std::vector<StatusRow>& rows, int width, bool colour) {
  const std::vector<std::string> header{"ROBOT",    "PROCESS",  "STATE",     "CHANNEL", "RATE/Hz",
                                        "LAT50/ms", "LAT95/ms", "PROC95/ms", "DROPS",   "ERRORS",
                                        "RESTARTS", "NOTE",     "LAST ERROR"};
  constexpr std::size_t kStateColumn = 2;
  constexpr std::size_t kFirstNumber = 4;
  constexpr std::size_t kNoteColumn = 11;
  constexpr std::size_t kLastColumn = 12;
  std::vector<std::vector<std::string>> cells{header};
  for (const StatusRow& r : rows) {
    cells.push_back({r.robot, r.process, r.state, r.channel.empty() ? "-" : r.channel,
                     number(r.rate_hz), number(r.latency_p50_ms), number(r.latency_p95_ms),
                     number(r.processing_p95_ms), std::to_string(r.drops), std::to_string(r.errors),
                     std::to_string(r.restarts), r.note.empty() ? "-" : r.note, r.last_error});
  }
  std::vector<std::size_t> widths(header.size(), 0);
  for (const auto& line : cells) {
    for (std::size_t c = 0; c < kLastColumn; ++c)
      widths[c] = std::max(widths[c], line[c].size());
  }
  const std::size_t limit = static_cast<std::size_t>(std::max(width, 20));
  std::vector<std::string> out;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    std::string text;
    std::size_t state_begin = 0;
    for (std::size_t c = 0; c < header.size(); ++c) {
      if (c > 0) text += "  ";
      if (c == kStateColumn) state_begin = text.size();
      const std::string& cell = cells[i][c];
      const std::size_t pad = c < kLastColumn ? widths[c] - cell.size() : 0;
      const bool left_aligned = c < kFirstNumber || c == kNoteColumn;
      if (!left_aligned) text.append(pad, ' ');
      text += cell;
      if (left_aligned) text.append(pad, ' ');
    }
    while (!text.empty() && text.back() == ' ')
      text.pop_back();
    if (text.size() > limit) text.resize(limit);
    const std::size_t state_end = state_begin + widths[kStateColumn];
    if (colour && i > 0 && state_end <= text.size()) {
      text.insert(state_end, "\x1b[0m");
      text.insert(state_begin, colourOf(rows[i - 1].severity));
    } else if (colour && i == 0) {
      text = "\x1b[1m" + text + "\x1b[0m";
    }
    out.push_back(std::move(text));
  }
  return out;
}

std::string renderCompact(const std::vector<StatusRow>& rows) {
  if (rows.empty()) return "no processes";
  std::string line;
  int missing = 0;
  for (const StatusRow& r : rows) {
    // Not-built processes were announced at start; repeating them every line is noise.
    if (r.state == "missing") {
      ++missing;
      continue;
    }
    if (!line.empty()) line += " | ";
    line += fmt::format("{} {} {}", r.robot, r.process, r.state);
    if (r.rate_hz) line += fmt::format(" {:.1f}Hz", *r.rate_hz);
    if (r.restarts > 0) line += fmt::format(" restarts={}", r.restarts);
    if (r.errors > 0) line += fmt::format(" errors={}", r.errors);
    if (r.drops > 0) line += fmt::format(" drops={}", r.drops);
    if (!r.note.empty()) line += " (" + r.note + ")";
  }
  if (missing > 0) line += fmt::format("{}{} not built", line.empty() ? "" : " | ", missing);
  return line;
}

}  // namespace fieldline::launch
