#include "tools/team_relay/relay.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>

#include <stdexcept>

namespace fieldline::team_relay {
namespace {

LinkDelays flat(int n, double up, double down, double jitter = 0.0, double max_ms = 20.0) {
  const auto k = static_cast<std::size_t>(n);
  return {std::vector<double>(k, up), std::vector<double>(k, down), std::vector<double>(k, jitter),
          std::vector<double>(k, jitter), max_ms};
}

TEST(TeamRelay, ForwardsToEveryoneButTheSenderAfterUplinkPlusDownlink) {
  LinkDelays d = flat(3, 1.0, 2.0);
  d.up_ms = {1.0, 4.0, 1.0};
  Forwarder f(3, d, {}, 1);
  const std::vector<Copy> copies = f.route(2);
  ASSERT_EQ(copies.size(), 2u);
  EXPECT_EQ(copies[0].to, 1);
  EXPECT_EQ(copies[1].to, 3);
  EXPECT_DOUBLE_EQ(copies[0].delay_ms, 6.0);  // robot 2's uplink 4 + downlink 2
  EXPECT_EQ(f.counts().forwarded, 2);
}

TEST(TeamRelay, DelayIsCappedAndJitterOnlyAddsDelay) {
  Forwarder f(2, flat(2, 1.0, 1.0, 5.0, 12.0), {}, 3);
  for (int i = 0; i < 500; ++i) {
    const auto copies = f.route(1);
    ASSERT_EQ(copies.size(), 1u);
    EXPECT_GE(copies[0].delay_ms, 2.0);
    EXPECT_LE(copies[0].delay_ms, 12.0);
  }
}

TEST(TeamRelay, PartitionBlocksOnlyAcrossGroups) {
  Impairment imp;
  applyChange(imp, "partition=12|34");
  EXPECT_TRUE(sameSide(imp, 1, 2));
  EXPECT_FALSE(sameSide(imp, 1, 3));
  EXPECT_TRUE(sameSide(imp, 5, 6));  // in no group: unaffected
  Forwarder f(4, flat(4, 1.0, 1.0), imp, 1);
  const auto copies = f.route(3);
  ASSERT_EQ(copies.size(), 1u);
  EXPECT_EQ(copies[0].to, 4);
  EXPECT_EQ(f.counts().blocked, 2);
  applyChange(f.impairment(), "partition=none");
  EXPECT_EQ(f.route(3).size(), 3u);
}

TEST(TeamRelay, LossDuplicationAndReorderFollowTheirProbabilities) {
  Forwarder all_lost(6, flat(6, 1.0, 1.0), {1.0, 0.0, 0.0, {}}, 1);
  EXPECT_TRUE(all_lost.route(1).empty());
  EXPECT_EQ(all_lost.counts().dropped, 5);

  Forwarder doubled(6, flat(6, 1.0, 1.0), {0.0, 1.0, 0.0, {}}, 1);
  EXPECT_EQ(doubled.route(1).size(), 10u);

  Forwarder held(2, flat(2, 1.0, 1.0), {0.0, 0.0, 1.0, {}}, 1);
  const auto copies = held.route(1);
  ASSERT_EQ(copies.size(), 1u);
  EXPECT_GE(copies[0].delay_ms, 7.0);  // 2 ms plus 5-15 ms reordering

  Forwarder some_lost(6, flat(6, 1.0, 1.0), {0.3, 0.0, 0.0, {}}, 5);
  int sent = 0;
  for (int i = 0; i < 2000; ++i)
    sent += static_cast<int>(some_lost.route(1 + i % 6).size());
  EXPECT_NEAR(sent / 10000.0, 0.7, 0.03);
}

TEST(TeamRelay, UnknownSenderGoesToEveryRobotUnimpaired) {
  Impairment imp{1.0, 0.0, 0.0, {{1}, {2}}};
  Forwarder f(3, flat(3, 5.0, 5.0), imp, 1);
  const auto copies = f.route(0);
  ASSERT_EQ(copies.size(), 3u);
  for (const Copy& c : copies)
    EXPECT_EQ(c.delay_ms, 0.0);
  EXPECT_EQ(f.counts().foreign, 1);
  EXPECT_EQ(f.counts().dropped, 0);
}

TEST(TeamRelay, SameSeedSameRoutes) {
  Forwarder a(6, flat(6, 1.0, 1.0, 3.0), {0.2, 0.1, 0.1, {}}, 9);
  Forwarder b(6, flat(6, 1.0, 1.0, 3.0), {0.2, 0.1, 0.1, {}}, 9);
  for (int i = 0; i < 100; ++i) {
    const auto x = a.route(1 + i % 6), y = b.route(1 + i % 6);
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t k = 0; k < x.size(); ++k)
      EXPECT_EQ(x[k].delay_ms, y[k].delay_ms);
  }
}

TEST(TeamRelay, ArgumentsAreCheckedWithClearErrors) {
  EXPECT_EQ(parsePerRobot("3", 4, "--up-ms"), std::vector<double>(4, 3.0));
  EXPECT_EQ(parsePerRobot("1,2", 2, "--up-ms"), (std::vector<double>{1.0, 2.0}));
  EXPECT_THROW(parsePerRobot("1,2", 3, "--up-ms"), std::invalid_argument);
  const ScheduledChange c = parseScheduleEntry("2.5:loss=0.3,partition=123|456");
  EXPECT_DOUBLE_EQ(c.at_s, 2.5);
  EXPECT_EQ(c.text, "loss=0.3,partition=123|456");
  EXPECT_THROW(parseScheduleEntry("loss=0.3"), std::invalid_argument);
  EXPECT_THROW(parseScheduleEntry("1:los=0.3"), std::invalid_argument);
  EXPECT_THROW(parseScheduleEntry("1:partition=1x|2"), std::invalid_argument);
  const sockaddr_in a = parseIpv4Endpoint("10.0.0.7:47600");
  EXPECT_EQ(ntohs(a.sin_port), 47600);
  EXPECT_EQ(ntohl(a.sin_addr.s_addr), 0x0a000007u);
  EXPECT_THROW(parseIpv4Endpoint("10.0.0.7"), std::invalid_argument);
  EXPECT_THROW(parseIpv4Endpoint("robot1:47600"), std::invalid_argument);
  EXPECT_THROW(parseIpv4Endpoint("10.0.0.7:0"), std::invalid_argument);
  EXPECT_THROW(Forwarder(3, flat(2, 1.0, 1.0), {}, 1), std::invalid_argument);
}

}  // namespace
}  // namespace fieldline::team_relay
