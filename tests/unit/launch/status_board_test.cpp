#include <gtest/gtest.h>

#include "tools/launch/status_board.hpp"

namespace fieldline::launch {
namespace status_board_test {

using std::chrono::milliseconds;

struct ChannelSpec {
  std::string name;
  std::int8_t direction;
  float rate;
  std::int64_t drops;
  float p50, p95;
};

service_status_t makeStatus(std::string process, std::int32_t pid,
                            const std::vector<ChannelSpec>& channels) {
  service_status_t s{};
  s.process = std::move(process);
  s.pid = pid;
  s.state = service_status_t::STATE_OK;
  s.num_channels = static_cast<std::int32_t>(channels.size());
  for (const auto& c : channels) {
    s.channel.push_back(c.name);
    s.direction.push_back(c.direction);
    s.messages_total.push_back(100);
    s.rate_hz.push_back(c.rate);
    s.drops_total.push_back(c.drops);
    s.rejected_total.push_back(0);
    s.latency_p50_ms.push_back(c.p50);
    s.latency_p95_ms.push_back(c.p95);
    s.latency_max_ms.push_back(c.p95);
  }
  s.processing_p95_ms = 1.25f;
  return s;
}

constexpr auto IN = service_status_t::DIRECTION_IN;
constexpr auto OUT = service_status_t::DIRECTION_OUT;

const std::vector<ChannelSpec> kFusionChannels{{"SERVICE_STATUS", OUT, 1.0f, 0, 0.1f, 0.1f},
                                               {"ODOMETRY", IN, 50.0f, 3, 8.0f, 9.0f},
                                               {"VISION_LINES", IN, 30.0f, 2, 60.0f, 80.0f},
                                               {"ROBOT_STATE", OUT, 49.5f, 0, 12.5f, 20.0f},
                                               {"BALL_STATE", OUT, 30.0f, 0, 2.0f, 3.0f}};

ProcessRecord running(const std::string& name, int robot, pid_t pid,
                      SteadyClock::time_point started) {
  ProcessRecord r;
  r.instance.name = name;
  r.instance.robot = robot;
  r.instance.executable = "fieldline-" + name;
  r.state = ProcessState::kRunning;
  r.pid = pid;
  r.started = started;
  return r;
}

TEST(MainOutputChannel, BusiestOutputOtherThanStatus) {
  const service_status_t s = makeStatus("fusion", 1, kFusionChannels);
  EXPECT_EQ(mainOutputChannel(s, ""), 3u);
  EXPECT_EQ(mainOutputChannel(s, "BALL_STATE"), 4u);
  EXPECT_EQ(mainOutputChannel(s, "ODOMETRY"), std::nullopt);  // an input, not an output
  const service_status_t quiet =
      makeStatus("x", 1, {{"SERVICE_STATUS", OUT, 1.0f, 0, 0, 0}, {"ODOMETRY", IN, 5, 0, 0, 0}});
  EXPECT_EQ(mainOutputChannel(quiet, ""), std::nullopt);
}

TEST(StatusBoard, RowFromTheMatchingReport) {
  const auto t0 = SteadyClock::now();
  StatusBoard board;
  service_status_t s = makeStatus("fusion", 4242, kFusionChannels);
  s.num_errors = 2;
  s.error_kind = {"decode", "future_utime"};
  s.error_count = {2, 5};
  s.last_error = "ODOMETRY: utime\nfrom the future";
  board.onStatus(2, s, t0);
  // Same pid on another robot's bus (another machine in real life) must not be mixed in.
  board.onStatus(3, makeStatus("fusion", 4242, {}), t0);

  const auto rows = board.rows({running("fusion", 2, 4242, t0)}, false, t0 + milliseconds(500));
  ASSERT_EQ(rows.size(), 1u);
  const StatusRow& r = rows[0];
  EXPECT_EQ(r.robot, "r2");
  EXPECT_EQ(r.process, "fusion");
  EXPECT_EQ(r.state, "ok");
  EXPECT_EQ(r.severity, Severity::kGood);
  EXPECT_EQ(r.channel, "ROBOT_STATE");
  EXPECT_DOUBLE_EQ(*r.rate_hz, 49.5);
  EXPECT_DOUBLE_EQ(*r.latency_p50_ms, 12.5);
  EXPECT_DOUBLE_EQ(*r.latency_p95_ms, 20.0);
  EXPECT_DOUBLE_EQ(*r.processing_p95_ms, 1.25);
  EXPECT_EQ(r.drops, 5);   // inputs only: 3 + 2
  EXPECT_EQ(r.errors, 7);  // 2 + 5
  EXPECT_EQ(r.last_error, "ODOMETRY: utime from the future");
  EXPECT_EQ(board.reportsReceived(), 2);
}

TEST(StatusBoard, StatesFromReportAgeAndSupervisor) {
  const auto t0 = SteadyClock::now();
  StatusBoard board;
  service_status_t warn = makeStatus("a", 10, kFusionChannels);
  warn.state = service_status_t::STATE_WARN;
  service_status_t error = makeStatus("b", 11, kFusionChannels);
  error.state = service_status_t::STATE_ERROR;
  board.onStatus(1, warn, t0);
  board.onStatus(1, error, t0);

  std::vector<ProcessRecord> records{running("a", 1, 10, t0), running("b", 1, 11, t0),
                                     running("c", 1, 12, t0)};
  ProcessRecord waiting = running("d", 1, -1, t0);
  waiting.state = ProcessState::kWaiting;
  waiting.restarts = 3;
  waiting.last_error = "killed by SIGSEGV after 0.2 s";
  records.push_back(waiting);
  ProcessRecord missing = running("e", 1, -1, t0);
  missing.state = ProcessState::kMissing;
  records.push_back(missing);

  auto rows = board.rows(records, false, t0 + milliseconds(1000));
  EXPECT_EQ(rows[0].state, "warn");
  EXPECT_EQ(rows[1].state, "error");
  EXPECT_EQ(rows[1].severity, Severity::kBad);
  EXPECT_EQ(rows[2].state, "starting");  // no report yet, young
  EXPECT_FALSE(rows[2].rate_hz.has_value());
  EXPECT_EQ(rows[3].state, "waiting");
  EXPECT_EQ(rows[3].restarts, 3);
  EXPECT_EQ(rows[3].last_error, "killed by SIGSEGV after 0.2 s");
  EXPECT_EQ(rows[4].state, "missing");
  EXPECT_EQ(rows[4].last_error, "fieldline-e is not built");

  rows = board.rows(records, false, t0 + milliseconds(5000));
  EXPECT_EQ(rows[0].state, "stale");    // reports stopped
  EXPECT_EQ(rows[2].state, "running");  // never reported (not a bus node)
  rows = board.rows(records, true, t0 + milliseconds(1000));
  EXPECT_EQ(rows[0].state, "stopping");
}

TEST(StatusBoard, WrapperProcessMatchedByNameAfterItStarted) {
  const auto t0 = SteadyClock::now();
  StatusBoard board;
  board.onStatus(1, makeStatus("camera", 500, kFusionChannels), t0 - milliseconds(100));
  const ProcessRecord wrapper = running("camera", 1, 499, t0);
  // The report predates this run: it belongs to an earlier instance.
  EXPECT_EQ(board.rows({wrapper}, false, t0).at(0).state, "starting");
  board.onStatus(1, makeStatus("camera", 501, kFusionChannels), t0 + milliseconds(10));
  EXPECT_EQ(board.rows({wrapper}, false, t0 + milliseconds(20)).at(0).state, "ok");
}

std::vector<StatusRow> twoRows() {
  StatusRow a;
  a.robot = "r1";
  a.process = "camera";
  a.state = "ok";
  a.severity = Severity::kGood;
  a.channel = "CAMERA_IMAGE";
  a.rate_hz = 30.0;
  a.latency_p50_ms = 0.25;
  a.latency_p95_ms = 1.5;
  a.processing_p95_ms = 12.0;
  StatusRow b;
  b.robot = "sim";
  b.process = "world_sim";
  b.state = "waiting";
  b.severity = Severity::kBad;
  b.restarts = 2;
  b.errors = 4;
  b.drops = 1;
  b.last_error = "exit code 1 after 0.3 s";
  return {a, b};
}

TEST(RenderTable, AlignedColumns) {
  auto rows = twoRows();
  rows[0].note = "render 0.41 ms";
  const auto lines = renderTable(rows, 200, false);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0],
            "ROBOT  PROCESS    STATE    CHANNEL       RATE/Hz  LAT50/ms  LAT95/ms  PROC95/ms  "
            "DROPS  ERRORS  RESTARTS  NOTE            LAST ERROR");
  EXPECT_EQ(lines[1],
            "r1     camera     ok       CAMERA_IMAGE     30.0      0.25       1.5       12.0      "
            "0       0         0  render 0.41 ms");
  EXPECT_EQ(lines[2],
            "sim    world_sim  waiting  -                   -         -         -          -      "
            "1       4         2  -               exit code 1 after 0.3 s");
}

TEST(RenderTable, FitsTheWidthAndColoursOnlyTheState) {
  const auto plain = renderTable(twoRows(), 40, false);
  for (const auto& l : plain)
    EXPECT_LE(l.size(), 40u);
  const auto coloured = renderTable(twoRows(), 200, true);
  EXPECT_EQ(coloured[1].find("\x1b[32mok     \x1b[0m"), 18u);
  EXPECT_NE(coloured[2].find("\x1b[31;1mwaiting\x1b[0m"), std::string::npos);
  // Without the escapes the line is the plain one.
  std::string stripped = coloured[2];
  for (const std::string code : {"\x1b[31;1m", "\x1b[0m"})
    stripped.erase(stripped.find(code), code.size());
  EXPECT_EQ(stripped, renderTable(twoRows(), 200, false)[2]);
}

TEST(RenderCompact, OneLine) {
  EXPECT_EQ(renderCompact(twoRows()),
            "r1 camera ok 30.0Hz | sim world_sim waiting restarts=2 errors=4 drops=1");
  EXPECT_EQ(renderCompact({}), "no processes");
  auto rows = twoRows();
  StatusRow missing;
  missing.robot = "r2";
  missing.process = "pilot";
  missing.state = "missing";
  rows.insert(rows.begin(), missing);
  rows.push_back(missing);
  EXPECT_EQ(
      renderCompact(rows),
      "r1 camera ok 30.0Hz | sim world_sim waiting restarts=2 errors=4 drops=1 | 2 not built");
  EXPECT_EQ(renderCompact({missing}), "1 not built");
}

}  // namespace status_board_test
}  // namespace fieldline::launch

namespace fieldline::launch {
namespace status_board_test {

TEST(HeadlineMetrics, PicksTheMetricsAPersonWatches) {
  service_status_t s{};
  s.num_metrics = 3;
  s.metric_name = {"serial_reconnects", "speed_mps", "render_ms"};
  s.metric_value = {2.0, 1.234, 0.41};
  EXPECT_EQ(headlineMetrics(s), "speed 1.23 m/s, render 0.41 ms");
  // Feature recognition shows its features per second by kind.
  s.num_metrics = 4;
  s.metric_name = {"recognition_ms", "circles_per_s", "corners_per_s", "other_features_per_s"};
  s.metric_value = {0.05, 10.0, 3.0, 22.0};
  EXPECT_EQ(headlineMetrics(s), "circles 10.0 /s, corners 3.0 /s, other 22.0 /s");
  s.metric_name = {"serial_reconnects"};
  s.metric_value = {2.0};
  s.num_metrics = 1;
  EXPECT_EQ(headlineMetrics(s), "");
}

TEST(StatusBoard, FusionNoteShowsTheStatusAndAnAmbiguousTwin) {
  service_status_t s{};
  s.num_metrics = 3;
  s.metric_name = {"ambiguous", "localization_status", "correction_cm"};
  s.metric_value = {0.0, 2.0, 1.5};
  EXPECT_EQ(headlineMetrics(s), "TRACKING, corr 1.5 cm");
  s.metric_value = {1.0, 2.0, 1.5};
  EXPECT_EQ(headlineMetrics(s), "TRACKING (twin?), corr 1.5 cm");
}

TEST(StatusBoard, TeamcommNoteShowsTeammatesOffsetUncertaintyAndRejections) {
  service_status_t s{};
  s.num_metrics = 4;
  s.metric_name = {"team_ball_rejected", "teammates_present", "offset_uncertainty_ms",
                   "packets_rejected"};
  s.metric_value = {0.0, 5.0, 1.25, 17.0};
  EXPECT_EQ(headlineMetrics(s), "team 5, offset +- 1.25 ms, rejected 17");
}

}  // namespace status_board_test
}  // namespace fieldline::launch
