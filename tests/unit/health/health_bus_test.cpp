// Issue 13, the bus side: per-publisher seq tracking that a forged seq cannot poison (finding 1),
// two processes publishing one channel reported as an error naming both (finding 2), input
// liveness (finding 3) and bounded stamps (finding 4). In-process over memq:// with a
// simulated clock.
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"

namespace fieldline::bus {
namespace health_bus_test {

class HealthBus : public ::testing::Test {
 protected:
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<Connection> memq = Connection::open("memq://");
  Node receiver{{.process = "receiver", .robot_id = 1, .status_period_us = 0}, clock, memq};
  Node injector{{.process = "injector", .robot_id = 1, .status_period_us = 0}, clock, memq};

  void spin() {
    for (int i = 0; i < 5; ++i)
      receiver.spinOnce(0);
  }
  // Sends an odometry message with the given header fields as raw bytes (a hostile sender).
  void inject(std::int64_t seq, std::int64_t publisher_id, Utime utime, Utime published) {
    odometry_t o{};
    o.header.utime = utime;
    o.header.utime_published = published;
    o.header.seq = seq;
    o.header.robot_id = 1;
    o.header.publisher_id = publisher_id;
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(o.getEncodedSize()));
    o.encode(buf.data(), 0, static_cast<int>(buf.size()));
    injector.publishEncoded(channels::kOdometry.name, buf.data(), static_cast<int>(buf.size()));
  }
  const ChannelStats& odometryIn() {
    const ChannelStats* in = receiver.status().channel("ODOMETRY", Direction::kIn);
    EXPECT_NE(in, nullptr);
    return *in;
  }
};

TEST_F(HealthBus, PublishersGetDistinctNonZeroIds) {
  EXPECT_NE(receiver.publisherId(), 0);
  EXPECT_NE(receiver.publisherId(), injector.publisherId());
  Node sender{{.process = "sender", .robot_id = 1, .status_period_us = 0}, clock, memq};
  std::vector<std::int64_t> ids;
  receiver.subscribe(channels::kOdometry,
                     [&](const odometry_t& m) { ids.push_back(m.header.publisher_id); });
  odometry_t o{};
  o.header.utime = clock.now();
  sender.publish(channels::kOdometry, o);
  spin();
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(ids[0], sender.publisherId());
}

// Finding 1: one valid message with seq = 1e15 set DROPS to 1e15 for the rest of the run. Since
// issue 34 (finding 6) a jump no publisher could make is a suspicious seq, not a resync.
TEST_F(HealthBus, ForgedSeqJumpIsOneSuspiciousSeqNotBillionsOfDrops) {
  receiver.subscribe(channels::kOdometry, [](const odometry_t&) {});
  const std::int64_t id = 77;
  for (std::int64_t seq = 0; seq < 10; ++seq)
    inject(seq, id, clock.now(), clock.now());
  inject(1'000'000'000'000'000, id, clock.now(), clock.now());
  for (std::int64_t seq = 10; seq < 20; ++seq)
    inject(seq, id, clock.now(), clock.now());
  spin();
  EXPECT_EQ(odometryIn().total, 21);
  EXPECT_EQ(odometryIn().drops, 0);
  EXPECT_EQ(odometryIn().suspicious, 1);
  EXPECT_EQ(receiver.status().errorCount("seq_suspicious"), 1);
}

// Gaps a 50 Hz publisher makes (its stamps say how much time passed: seq_tracker.hpp).
TEST_F(HealthBus, PlausibleGapsStillCountAsDrops) {
  receiver.subscribe(channels::kOdometry, [](const odometry_t&) {});
  const Utime base = clock.now();
  for (std::int64_t seq : {0, 1, 5, 6, 506}) {
    clock.advance(base + seq * 20'000 - clock.now());
    inject(seq, 9, clock.now(), clock.now());
    spin();
  }
  spin();
  EXPECT_EQ(odometryIn().drops, 3 + 499);
  EXPECT_EQ(odometryIn().resyncs, 0);
}

// A second publisher with the same robot_id used to be read as one sender jumping back and forth.
TEST_F(HealthBus, SeqIsTrackedPerPublisherNotPerRobot) {
  receiver.subscribe(channels::kOdometry, [](const odometry_t&) {});
  // Two publishers, interleaved, each without a loss. A restart (a new id, seq from 0) neither.
  for (std::int64_t seq = 0; seq < 50; ++seq) {
    inject(seq, 1, clock.now(), clock.now());
    inject(100'000 + seq, 2, clock.now(), clock.now());
  }
  spin();
  EXPECT_EQ(odometryIn().drops, 0);
  EXPECT_EQ(odometryIn().resyncs, 0);
}

// Finding 2: two processes commanding one robot were invisible.
TEST_F(HealthBus, TwoPublishersOnASinglePublisherChannelIsAnErrorNamingBoth) {
  receiver.subscribe(channels::kOdometry, [](const odometry_t&) {});
  for (std::int64_t seq = 0; seq < 20; ++seq) {
    inject(seq, 0x1111, clock.now(), clock.now());
    inject(seq, 0x2222, clock.now(), clock.now());
    clock.advance(20'000);
  }
  spin();
  const service_status_t s = receiver.status().takeStatus(clock.now());
  EXPECT_EQ(s.state, service_status_t::STATE_ERROR);
  EXPECT_NE(s.state_reason.find("ODOMETRY: two publishers"), std::string::npos) << s.state_reason;
  EXPECT_NE(s.state_reason.find("1111"), std::string::npos) << s.state_reason;
  EXPECT_NE(s.state_reason.find("2222"), std::string::npos) << s.state_reason;
  EXPECT_EQ(receiver.status().errorCount("two_publishers"), 1);  // once, not per message
  // The second one goes away: ok again after the window.
  for (std::int64_t seq = 20; seq < 200; ++seq) {
    inject(seq, 0x1111, clock.now(), clock.now());
    clock.advance(20'000);
  }
  spin();
  receiver.status().takeStatus(clock.now());
  EXPECT_EQ(receiver.status().takeStatus(clock.now() + 1).state, service_status_t::STATE_OK);
}

TEST_F(HealthBus, ARestartIsNotTwoPublishers) {
  receiver.subscribe(channels::kOdometry, [](const odometry_t&) {});
  for (std::int64_t seq = 0; seq < 20; ++seq) {
    inject(seq, 0x1111, clock.now(), clock.now());
    clock.advance(20'000);
  }
  for (std::int64_t seq = 0; seq < 20; ++seq) {
    inject(seq, 0x3333, clock.now(), clock.now());
    clock.advance(20'000);
  }
  spin();
  const service_status_t s = receiver.status().takeStatus(clock.now());
  EXPECT_EQ(s.state, service_status_t::STATE_OK) << s.state_reason;
  EXPECT_EQ(odometryIn().drops, 0);
}

TEST_F(HealthBus, SeveralPublishersOnServiceStatusAreFine) {
  receiver.subscribe(channels::kServiceStatus, [](const service_status_t&) {});
  Node a{{.process = "a", .robot_id = 1, .status_period_us = 0}, clock, memq};
  Node b{{.process = "b", .robot_id = 1, .status_period_us = 0}, clock, memq};
  for (int i = 0; i < 5; ++i) {
    a.publishStatus();
    b.publishStatus();
  }
  spin();
  EXPECT_EQ(receiver.status().takeStatus(clock.now()).state, service_status_t::STATE_OK);
}

TEST_F(HealthBus, PublisherTableIsBounded) {
  receiver.subscribe(channels::kOdometry, [](const odometry_t&) {});
  for (std::int64_t id = 1; id <= 10'000; ++id)
    inject(0, id, clock.now(), clock.now());
  spin();
  for (int i = 0; i < 100; ++i)
    receiver.spinOnce(0);
  EXPECT_LE(odometryIn().publishers.size(), StatusCollector::kMaxPublishersPerChannel);
}

// Finding 4: utime = 1, utime_published = INT64_MAX was accepted (latency 9.2e15 ms).
TEST_F(HealthBus, AbsurdStampsAreRejectedAndCounted) {
  int handled = 0;
  receiver.subscribe(channels::kOdometry, [&](const odometry_t&) { ++handled; });
  const Utime now = clock.now();
  const Utime kMax = std::numeric_limits<Utime>::max();
  inject(0, 5, 1, kMax);  // published in the future
  inject(1, 5, 1, now);   // latency of 56 years
  inject(2, 5, now - 60 * kMicrosPerSecond, now - 60 * kMicrosPerSecond);  // a replayed log
  inject(3, 5, now, now - kMicrosPerSecond);                 // observed after it was published
  inject(4, 5, std::numeric_limits<Utime>::min() + 1, now);  // overflows a naive difference
  inject(5, 5, now - 50'000, now);                           // fine
  spin();
  EXPECT_EQ(handled, 1);
  EXPECT_EQ(odometryIn().rejected, 5);
  EXPECT_EQ(receiver.status().errorCount("future_utime"), 1);
  EXPECT_EQ(receiver.status().errorCount("stale"), 1);
  EXPECT_EQ(receiver.status().errorCount("bad_stamps"), 2);
  EXPECT_EQ(receiver.status().errorCount("invalid"), 1);
  const service_status_t s = receiver.status().takeStatus(clock.now());
  ASSERT_EQ(s.num_channels, 1);
  EXPECT_NEAR(s.latency_max_ms[0], 50.0f, 1e-3f);
}

// Finding 3: region_tracking said ok at 0.0 Hz while its camera was dead (here: a process
// that needs ODOMETRY at 20 Hz).
TEST_F(HealthBus, ASilentRequiredInputIsAWarningWithTheReasonAndRecovers) {
  Node tracker{
      {.process = "tracker", .robot_id = 1, .input_grace_us = 2 * kMicrosPerSecond}, clock, memq};
  Node camera{{.process = "camera", .robot_id = 1, .status_period_us = 0}, clock, memq};
  tracker.subscribe(channels::kOdometry, [](const odometry_t&) {});
  tracker.requireInput(channels::kOdometry, 20.0);
  std::vector<service_status_t> reports;
  Node monitor{{.process = "monitor", .robot_id = 1, .status_period_us = 0}, clock, memq};
  monitor.subscribe(channels::kServiceStatus, [&](const service_status_t& s) {
    if (s.process == "tracker") reports.push_back(s);
  });
  auto run = [&](double seconds, bool camera_on) {
    for (int i = 0; i < static_cast<int>(seconds * 30); ++i) {
      if (camera_on) {
        odometry_t o{};
        o.header.utime = clock.now();
        camera.publish(channels::kOdometry, o);
      }
      clock.advance(kMicrosPerSecond / 30);
      for (int k = 0; k < 3; ++k) {
        tracker.spinOnce(0);
        monitor.spinOnce(0);
      }
    }
  };
  run(3.05, true);
  ASSERT_FALSE(reports.empty());
  EXPECT_EQ(reports.back().state, service_status_t::STATE_OK) << reports.back().state_reason;
  run(1.0, false);  // within the grace time
  EXPECT_EQ(reports.back().state, service_status_t::STATE_OK) << reports.back().state_reason;
  run(2.0, false);
  EXPECT_EQ(reports.back().state, service_status_t::STATE_WARN);
  EXPECT_NE(reports.back().state_reason.find("ODOMETRY silent"), std::string::npos)
      << reports.back().state_reason;
  run(2.0, true);
  EXPECT_EQ(reports.back().state, service_status_t::STATE_OK) << reports.back().state_reason;
}

TEST_F(HealthBus, AnInputBelowItsRateIsAWarning) {
  StatusCollector c("p", 1, 0);
  c.requireRate("ODOMETRY", Direction::kIn, 40.0);
  Utime t = 0;
  for (int second = 1; second <= 4; ++second) {
    for (int i = 0; i < 10; ++i) {
      t += 100'000;
      c.onReceived("ODOMETRY", Received{.seq = t / 100'000, .utime = t, .utime_published = t}, t,
                   true);
    }
    const service_status_t s = c.takeStatus(second * kMicrosPerSecond);
    if (second < 2) {
      EXPECT_EQ(s.state, service_status_t::STATE_OK);
    } else {
      EXPECT_EQ(s.state, service_status_t::STATE_WARN);
      EXPECT_NE(s.state_reason.find("ODOMETRY at 10.0 Hz < 40.0 Hz"), std::string::npos)
          << s.state_reason;
    }
  }
}

}  // namespace health_bus_test
}  // namespace fieldline::bus

// Finding 8: `--fps 1000` exited 105 (CLI11's code) instead of the documented 2.
namespace fieldline::bus {
namespace health_bus_test {

TEST(HealthCli, BadArgumentsExitWithTwoHelpWithZero) {
  auto parse = [](std::vector<std::string> args) {
    cli::App app{"test"};
    double fps = 30;
    app.add_option("--fps", fps)->check(cli::Range(1.0, 120.0));
    std::vector<char*> argv;
    for (auto& a : args)
      argv.push_back(a.data());
    return parseCommandLine(app, static_cast<int>(argv.size()), argv.data());
  };
  EXPECT_EQ(parse({"prog", "--fps", "1000"}), 2);  // out of range: CLI11 says 105
  EXPECT_EQ(parse({"prog", "--feild"}), 2);        // unknown option
  EXPECT_EQ(parse({"prog", "--fps", "x"}), 2);
  EXPECT_EQ(parse({"prog", "--help"}), 0);
  EXPECT_EQ(parse({"prog", "--fps", "25"}), std::nullopt);
}

}  // namespace health_bus_test
}  // namespace fieldline::bus
