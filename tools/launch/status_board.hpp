// The launcher's view of its processes' health: the latest SERVICE_STATUS of each process (from
// every bus the launcher started processes on), combined with what the supervisor knows
// (running, waiting for a restart, restarts), as table rows, a full table or a compact line.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fieldline/service_status_t.hpp>

#include "tools/launch/supervisor.hpp"

namespace fieldline::launch {

// How a row is coloured.
enum class Severity { kGood, kNotice, kBad, kIdle };

struct StatusRow {
  // "r1", "sim".
  std::string robot;
  std::string process;
  // ok, warn, error (the process's own report), suspect (a report with impossible numbers),
  // starting, stale (its reports stopped), running (no report yet), waiting (for a restart),
  // stopping, stopped, exited, failed, missing.
  std::string state;
  Severity severity = Severity::kIdle;
  // The main output channel and its rate, latency (utime_published - utime) percentiles.
  std::string channel;
  std::optional<double> rate_hz;
  std::optional<double> latency_p50_ms;
  std::optional<double> latency_p95_ms;
  // Processing time per handled message, 95th percentile.
  std::optional<double> processing_p95_ms;
  // Input messages missing by seq gaps, since the process started.
  std::int64_t drops = 0;
  // Errors of every kind, since the process started.
  std::int64_t errors = 0;
  int restarts = 0;
  // The process's headline metrics from SERVICE_STATUS, e.g. "speed 1.21 m/s".
  std::string note;
  std::string last_error;
  // Values of the report that are not plausible measurements (rate 1e30 Hz), dropped from the
  // row; a row with any is shown as `suspect`, whatever the report's state.
  std::string untrusted;
};

class StatusBoard {
 public:
  // A report older than this while the process runs makes its state `stale`.
  static constexpr double kStaleAfterS = 3.5;

  // A SERVICE_STATUS received on the bus of robot `bus_robot` at `now`.
  void onStatus(int bus_robot, const service_status_t& status, SteadyClock::time_point now);

  // One row per process, in the supervisor's order.
  std::vector<StatusRow> rows(const std::vector<ProcessRecord>& processes, bool stopping,
                              SteadyClock::time_point now) const;

  // Reports received so far (all buses).
  std::int64_t reportsReceived() const { return reports_; }

 private:
  struct Report {
    service_status_t status;
    SteadyClock::time_point received;
  };
  const Report* find(const ProcessRecord& record) const;

  // Latest report per (bus robot, pid).
  std::map<std::pair<int, std::int32_t>, Report> latest_;
  std::int64_t reports_ = 0;
};

// Picks the channel a row reports: `preferred` if the process publishes it, else its busiest
// output other than SERVICE_STATUS. Returns the index into status.channel, or nothing.
std::optional<std::size_t> mainOutputChannel(const service_status_t& status,
                                             const std::string& preferred);

// A short text of the metrics a person watching the team cares about (robot speed, render time,
// touched fraction, ...), from the process-specific metrics of a status report.
std::string headlineMetrics(const service_status_t& status);

// The table as lines (header first) no wider than `width` characters on screen; with `colour`,
// the state column carries ANSI colours.
std::vector<std::string> renderTable(const std::vector<StatusRow>& rows, int width, bool colour);

// One line for logs: "r1 camera ok 30.0Hz | r2 camera waiting restarts=2 | 3 not built".
std::string renderCompact(const std::vector<StatusRow>& rows);

}  // namespace fieldline::launch
