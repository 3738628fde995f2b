// Issue 13, finding 4 on the launcher's table: a forged SERVICE_STATUS with a rate of 1e30 Hz
// was shown as such, in an "ok" row. Impossible values are dropped and the row is flagged.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "tools/launch/status_board.hpp"

namespace fieldline::launch {
namespace health_board_test {

service_status_t report(float rate_hz, float latency_ms) {
  service_status_t s{};
  s.process = "region_tracking";
  s.pid = 77;
  s.state = service_status_t::STATE_OK;
  s.num_channels = 1;
  s.channel = {"VISION_LINES"};
  s.direction = {service_status_t::DIRECTION_OUT};
  s.messages_total = {10};
  s.rate_hz = {rate_hz};
  s.drops_total = {0};
  s.rejected_total = {0};
  s.latency_p50_ms = {latency_ms};
  s.latency_p95_ms = {latency_ms};
  s.latency_max_ms = {latency_ms};
  s.processing_p95_ms = 2.0f;
  return s;
}

ProcessRecord running(SteadyClock::time_point started) {
  ProcessRecord r;
  r.instance.name = "region_tracking";
  r.instance.robot = 1;
  r.instance.executable = "fieldline-region-tracking";
  r.state = ProcessState::kRunning;
  r.pid = 77;
  r.started = started;
  return r;
}

StatusRow rowFor(const service_status_t& s) {
  const auto t0 = SteadyClock::now();
  StatusBoard board;
  board.onStatus(1, s, t0);
  const auto rows = board.rows({running(t0)}, false, t0 + std::chrono::milliseconds(100));
  EXPECT_EQ(rows.size(), 1u);
  return rows.at(0);
}

TEST(HealthBoard, PlausibleReportIsShownAsIs) {
  const StatusRow r = rowFor(report(30.0f, 60.0f));
  EXPECT_EQ(r.state, "ok");
  EXPECT_DOUBLE_EQ(*r.rate_hz, 30.0);
  EXPECT_TRUE(r.untrusted.empty());
}

TEST(HealthBoard, AbsurdRateIsDroppedAndFlagged) {
  const StatusRow r = rowFor(report(1e30f, 60.0f));
  EXPECT_EQ(r.state, "suspect");
  EXPECT_FALSE(r.rate_hz.has_value());
  EXPECT_NE(r.last_error.find("rate_hz 1e+30"), std::string::npos) << r.last_error;
}

TEST(HealthBoard, AbsurdOrNonFiniteLatencyIsDroppedAndFlagged) {
  StatusRow r = rowFor(report(30.0f, 9.2e15f));
  EXPECT_EQ(r.state, "suspect");
  EXPECT_FALSE(r.latency_p50_ms.has_value());
  r = rowFor(report(30.0f, std::numeric_limits<float>::quiet_NaN()));
  EXPECT_EQ(r.state, "suspect");
  EXPECT_FALSE(r.latency_p95_ms.has_value());
}

TEST(HealthBoard, NegativeDropsAreNotAdded) {
  service_status_t s = report(30.0f, 60.0f);
  s.num_channels = 2;
  s.channel.push_back("CAMERA_IMAGE");
  s.direction.push_back(service_status_t::DIRECTION_IN);
  s.messages_total.push_back(1);
  s.rate_hz.push_back(30.0f);
  s.drops_total.push_back(-5);
  s.rejected_total.push_back(0);
  s.latency_p50_ms.push_back(1.0f);
  s.latency_p95_ms.push_back(1.0f);
  s.latency_max_ms.push_back(1.0f);
  const StatusRow r = rowFor(s);
  EXPECT_EQ(r.drops, 0);
  EXPECT_EQ(r.state, "suspect");
}

TEST(HealthBoard, TheReasonOfAWarningIsShown) {
  service_status_t s = report(0.0f, 0.0f);
  s.state = service_status_t::STATE_WARN;
  s.state_reason = "CAMERA_IMAGE silent 2.1 s";
  const StatusRow r = rowFor(s);
  EXPECT_EQ(r.state, "warn");
  EXPECT_EQ(r.last_error, "CAMERA_IMAGE silent 2.1 s");
}

}  // namespace health_board_test
}  // namespace fieldline::launch
