// Red-team findings of issue 34 on the team link, each reproduced as the red team found it.
//
// Run against main at 32dcf7a (before the fixes), each of these failed:
// - redteam_clock_step (finding 2): robot 1 was never present again at its teammates after any
//   of the steps ("present 0 %" for the rest of the run), and their SERVICE_STATUS reason was
//   "robot 1 sequence N", not the clock.
// - redteam_kernel_drops (finding 9): after a flood the kernel dropped thousands of datagrams of,
//   no kernel_drops metric, and the reason named only the refused junk ("200-byte datagram
//   claiming robot 90").
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "tests/unit/teamcomm/team_harness.hpp"

namespace fieldline::teamcomm {
namespace redteam_test {

using namespace test;

std::string reasonOf(Robot& r) {
  return r.node.status().takeStatus(r.clock.now()).state_reason;
}

// Seconds of running until every other robot's newest TEAM_STATE shows robot `index` present
// with a pose younger than 0.2 s again (at most `limit_s`), -1 when they never do.
double secondsUntilSeenAgain(Team& team, std::size_t index, double limit_s) {
  for (int step = 1; step <= static_cast<int>(limit_s * 10); ++step) {
    team.run(0.1);
    bool all = true;
    for (std::size_t i = 0; i < team.robots.size(); ++i) {
      if (i == index) continue;
      const auto& states = team.robots[i]->states;
      if (states.empty()) return -1;
      const perception::TeammateState& m = states.back().robots[index];
      all = all && m.present && m.robot_age_us < 200'000;
    }
    if (all) return 0.1 * step;
  }
  return -1;
}

// Every other robot's offset estimate of robot `index` against the truth, µs (largest error).
double worstOffsetError(Team& team, std::size_t index) {
  double worst = 0.0;
  for (std::size_t i = 0; i < team.robots.size(); ++i) {
    if (i == index) continue;
    const auto e =
        team.robots[i]->team.offset(static_cast<int>(index) + 1, team.robots[i]->clock.now());
    if (!e) return 1e12;
    worst = std::max(worst, std::abs(e->offset_us - team.trueOffset(i, index)));
  }
  return worst;
}

// Finding 2: robot 1's clock steps by +2 s and by -2 s while the team runs (an NTP step).
TEST(redteam_clock_step, ARunningRobotsClockSteppedBy2sIsSeenAgainWithin5s) {
  Team team({{0, 0.0}, {437'000, 40.0}, {-312'000, -30.0}});
  team.run(6.0);
  ASSERT_GT(secondsUntilSeenAgain(team, 0, 1.0), 0.0);
  for (const Utime step : {Utime{2'000'000}, Utime{-2'000'000}}) {
    team.robots[0]->clock.step(step);
    team.run(0.2);
    // While it happens the teammates say why: the clock, not a sequence number.
    for (std::size_t i = 1; i < 3; ++i) {
      const std::string reason = reasonOf(*team.robots[i]);
      EXPECT_NE(reason.find("robot 1"), std::string::npos) << reason;
      EXPECT_NE(reason.find("clock"), std::string::npos) << reason;
      EXPECT_EQ(reason.find("sequence"), std::string::npos) << reason;
    }
    const double back = secondsUntilSeenAgain(team, 0, 5.0);
    EXPECT_GT(back, 0.0) << "step " << step << " µs: robot 1 not seen again within 5 s";
    std::printf("step %+lld µs: robot 1 seen again after %.1f s (+0.2 s)\n",
                static_cast<long long>(step), back);
    team.run(4.0);
    EXPECT_LT(worstOffsetError(team, 0), 1000.0) << "step " << step << " µs";
    // Robot 1 hears its teammates again too.
    const perception::TeamState& own = team.robots[0]->states.back();
    EXPECT_TRUE(own.robots[1].present && own.robots[2].present) << "step " << step;
  }
}

// Finding 2 as the red team did it: robot 1's processes restarted on a clock 2 s ahead, then on
// one 2 s behind (within a second of the previous start: its sequence numbers go back too).
TEST(redteam_clock_step, ARobotRestartedOnAClock2sAheadOrBehindIsSeenAgainWithin5s) {
  Team team({{0, 0.0}, {437'000, 40.0}, {-312'000, -30.0}});
  team.run(6.0);
  struct Restart {
    Utime offset_us;
    double run_before_s;
  };
  for (const Restart r : {Restart{2'000'000, 0.0}, Restart{-2'000'000, 0.0}, Restart{0, 0.0},
                          Restart{-2'000'000, 1.0}}) {
    team.run(r.run_before_s);
    team.restart(0, r.offset_us, 0.0);
    const double back = secondsUntilSeenAgain(team, 0, 5.0);
    EXPECT_GT(back, 0.0) << "restart at " << r.offset_us << " µs: not seen again within 5 s";
    std::printf("restart at %+lld µs: robot 1 seen again after %.1f s\n",
                static_cast<long long>(r.offset_us), back);
    team.run(3.0);
    EXPECT_LT(worstOffsetError(team, 0), 1000.0) << "restart at " << r.offset_us << " µs";
    for (std::size_t i = 1; i < 3; ++i) {
      EXPECT_TRUE(team.robots[i]->states.back().robots[0].present)
          << "robot " << i + 1 << " after the restart at " << r.offset_us << " µs";
    }
  }
}

// Finding 9: a flood the kernel drops datagrams of shows in SERVICE_STATUS.
TEST(redteam_kernel_drops, AFloodsKernelDropsShowInTheStatus) {
  // Free ports on the loopback interface: the link's, and its peer's (nobody listens there, so
  // the node does not hear its own packets).
  const auto freePort = [] {
    const int probe = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in any{};
    any.sin_family = AF_INET;
    any.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof any;
    if (probe < 0 || ::bind(probe, reinterpret_cast<sockaddr*>(&any), sizeof any) != 0 ||
        ::getsockname(probe, reinterpret_cast<sockaddr*>(&any), &len) != 0) {
      return std::uint16_t{0};
    }
    ::close(probe);
    return ntohs(any.sin_port);
  };
  const std::uint16_t port = freePort(), peer = freePort();
  ASSERT_NE(port, 0);
  ASSERT_NE(peer, 0);

  UdpOptions udp;
  udp.group.clear();
  udp.port = port;
  udp.peers = {"127.0.0.1:" + std::to_string(peer)};
  std::unique_ptr<PacketLink> link = openUdpLink(udp);
  SimulatedClock clock(kT0);
  auto bus = bus::Connection::open("memq://");
  bus::Node node({.process = "teamcomm", .robot_id = 1, .status_period_us = 0}, clock, bus);
  TeamcommOptions options;
  options.key = devKey();
  options.expect_own_echo = false;
  TeamcommNode team(node, *link, options);

  // 50,000 datagrams while the node is busy elsewhere: the receive buffer overflows.
  int flood = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(flood, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const std::vector<std::uint8_t> junk(200, 0x5a);
  for (int i = 0; i < 50'000; ++i) {
    (void)::sendto(flood, junk.data(), junk.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
  }
  // A few after the node has read the backlog, carrying the kernel's final count.
  for (int step = 0; step < 300; ++step) {
    clock.advance(5'000);
    node.spinOnce(0);
    if (step == 200) {
      for (int i = 0; i < 5; ++i)
        (void)::sendto(flood, junk.data(), junk.size(), 0, reinterpret_cast<sockaddr*>(&to),
                       sizeof to);
    }
  }
  ::close(flood);
  const service_status_t status = node.status().takeStatus(clock.now());
  double drops = -1.0;
  for (int i = 0; i < status.num_metrics; ++i) {
    if (status.metric_name[static_cast<std::size_t>(i)] == "kernel_drops")
      drops = status.metric_value[static_cast<std::size_t>(i)];
  }
  EXPECT_GT(drops, 1000.0) << "no kernel_drops metric, or too few";
  EXPECT_EQ(status.state, service_status_t::STATE_WARN);
  EXPECT_NE(status.state_reason.find("kernel dropped"), std::string::npos) << status.state_reason;
}

}  // namespace redteam_test
}  // namespace fieldline::teamcomm
