#include <gtest/gtest.h>

#include "common/bus/status.hpp"

namespace fieldline::bus {
namespace status_test {

TEST(Percentiles, OfKnownSamples) {
  std::vector<float> s;
  for (int i = 100; i >= 1; --i)
    s.push_back(static_cast<float>(i));
  const Percentiles p = percentiles(s);
  EXPECT_FLOAT_EQ(p.p50, 50.0f);
  EXPECT_FLOAT_EQ(p.p95, 95.0f);
  EXPECT_FLOAT_EQ(p.max, 100.0f);
  std::vector<float> empty;
  EXPECT_FLOAT_EQ(percentiles(empty).max, 0.0f);
}

TEST(StatusCollector, RatesAndPeriodsReset) {
  StatusCollector c("p", 1, 0);
  for (int i = 0; i < 30; ++i)
    c.onPublished("CAMERA_IMAGE", i * 33'000, i * 33'000 + 60'000);
  auto s = c.takeStatus(1'000'000);
  ASSERT_EQ(s.num_channels, 1);
  EXPECT_FLOAT_EQ(s.rate_hz[0], 30.0f);
  EXPECT_FLOAT_EQ(s.latency_p50_ms[0], 60.0f);
  EXPECT_EQ(s.state, service_status_t::STATE_OK);
  s = c.takeStatus(2'000'000);
  EXPECT_FLOAT_EQ(s.rate_hz[0], 0.0f);
  EXPECT_EQ(s.messages_total[0], 30);
}

TEST(StatusCollector, DropsAreTrackedPerSender) {
  StatusCollector c("p", 1, 0);
  c.onReceived("TEAM", 1, 0, 1, 2);
  c.onReceived("TEAM", 2, 10, 1, 2);
  c.onReceived("TEAM", 1, 1, 1, 2);
  c.onReceived("TEAM", 2, 12, 1, 2);  // one lost from sender 2
  c.onReceived("TEAM", 1, 4, 1, 2);   // two lost from sender 1
  EXPECT_EQ(c.channel("TEAM", Direction::kIn)->drops, 3);
}

}  // namespace status_test
}  // namespace fieldline::bus

namespace fieldline::bus {
namespace status_test {

TEST(StatusCollector, StateFollowsErrorsAndFaults) {
  StatusCollector c("p", 1, 0);
  EXPECT_EQ(c.takeStatus(1'000'000).state, service_status_t::STATE_OK);
  c.onError("decode", "x", 1'500'000);
  EXPECT_EQ(c.takeStatus(2'000'000).state, service_status_t::STATE_WARN);
  EXPECT_EQ(c.takeStatus(3'000'000).state, service_status_t::STATE_OK);  // a new period
  c.setFault(true);
  EXPECT_EQ(c.takeStatus(4'000'000).state, service_status_t::STATE_ERROR);
  c.setFault(false);
  EXPECT_EQ(c.takeStatus(5'000'000).state, service_status_t::STATE_OK);
}

}  // namespace status_test
}  // namespace fieldline::bus
