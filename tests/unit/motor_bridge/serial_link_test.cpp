// The serial link over a real pseudo-terminal: bytes both ways, and reconnection
// after the device disappears and returns (the emulator closing and reopening its pty).
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>

#include <gtest/gtest.h>

#include "services/motor_bridge/serial_link.hpp"
#include "services/world_sim/pseudo_terminal.hpp"

namespace fieldline::motor_bridge {
namespace serial_link_test {

using Bytes = std::vector<std::uint8_t>;

class SerialLinkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() / ("fieldline-link-" + std::to_string(::getpid()));
    link_path = (dir / "robot1.tty").string();
  }
  void TearDown() override { std::filesystem::remove_all(dir); }

  // Drives the link as the bridge's event loop does (waits up to 5 ms on its descriptor, reads
  // when it is readable or hung up, then poll()) until `done` holds; gives up after many rounds
  // so a broken link fails the test instead of hanging it (the assertion is on `done`, not on
  // time).
  bool runUntil(SerialLink& link, const std::function<bool()>& done) {
    for (int round = 0; round < 2000 && !done(); ++round) {
      pollfd fd{.fd = link.nativeHandle(), .events = POLLIN, .revents = 0};
      // A negative descriptor is ignored by poll(): it sleeps the 5 ms then.
      if (::poll(&fd, 1, 5) > 0 && fd.revents != 0) link.onReadable();
      link.poll();
    }
    return done();
  }

  std::filesystem::path dir;
  std::string link_path;
};

TEST_F(SerialLinkTest, CarriesBytesAndReconnectsAfterTheDeviceReturns) {
  Bytes received;
  int ups = 0;
  int downs = 0;
  SerialLink link(
      {link_path, 115200, 0.02},
      [&](std::span<const std::uint8_t> b) { received.insert(received.end(), b.begin(), b.end()); },
      [&](bool up) { (up ? ups : downs)++; });

  // The device is not there yet: the link keeps trying.
  link.start();
  ASSERT_TRUE(runUntil(link, [&] { return link.stats().open_failures >= 2; }));
  EXPECT_FALSE(link.connected());
  EXPECT_FALSE(link.send(Bytes{1, 2, 3}));
  EXPECT_EQ(link.stats().bytes_dropped, 3u);

  auto pty = std::make_unique<world_sim::PseudoTerminal>(link_path);
  ASSERT_TRUE(runUntil(link, [&] { return link.connected(); }));
  EXPECT_EQ(ups, 1);

  // Emulator -> link, including zeros and CR/LF, unchanged.
  const Bytes down{0x00, 0x0a, 0x0d, 0x11, 0x13, 0xff};
  EXPECT_EQ(pty->write(down), 0u);
  ASSERT_TRUE(runUntil(link, [&] { return received.size() >= down.size(); }));
  EXPECT_EQ(received, down);
  // Link -> emulator.
  const Bytes up{0x7e, 0x00, 0x03};
  ASSERT_TRUE(link.send(up));
  Bytes got;
  ASSERT_TRUE(runUntil(link, [&] {
    pty->read(got);
    return got.size() >= up.size();
  }));
  EXPECT_EQ(got, up);

  // The device disappears: the link notices and reports it.
  pty.reset();
  ASSERT_TRUE(runUntil(link, [&] { return downs == 1; }));
  EXPECT_FALSE(link.connected());
  EXPECT_EQ(link.stats().disconnects, 1u);

  // ... and returns under the same name (a new pty number behind the link): reconnected.
  pty = std::make_unique<world_sim::PseudoTerminal>(link_path);
  ASSERT_TRUE(runUntil(link, [&] { return link.connected(); }));
  EXPECT_EQ(ups, 2);
  received.clear();
  EXPECT_EQ(pty->write(Bytes{0x42}), 0u);
  ASSERT_TRUE(runUntil(link, [&] { return !received.empty(); }));
  EXPECT_EQ(received, Bytes{0x42});
  ASSERT_TRUE(link.send(Bytes{0x43}));
  got.clear();
  ASSERT_TRUE(runUntil(link, [&] {
    pty->read(got);
    return !got.empty();
  }));
  EXPECT_EQ(got, Bytes{0x43});
  link.stop();
}

// After a stall of the bridge the pty holds a backlog of frames; the link hands it over in one
// piece, so the bridge can stamp each sample by its controller time relative to the newest.
TEST_F(SerialLinkTest, ABacklogArrivesInOneRead) {
  std::vector<std::size_t> reads;
  SerialLink link(
      {link_path, 115200, 0.02},
      [&](std::span<const std::uint8_t> b) { reads.push_back(b.size()); }, [](bool) {});
  auto pty = std::make_unique<world_sim::PseudoTerminal>(link_path);
  link.start();
  ASSERT_TRUE(runUntil(link, [&] { return link.connected(); }));
  // 0.7 s of 50 Hz odometry frames (about 40 bytes each), written while the link is not read.
  const Bytes backlog(35 * 40, 0x5a);
  ASSERT_EQ(pty->write(backlog), 0u);
  ASSERT_TRUE(runUntil(link, [&] { return !reads.empty(); }));
  EXPECT_EQ(reads.front(), backlog.size());
  link.stop();
}

// A device that stops taking bytes: send() queues what it did not take, keeps only the newest
// frames (a backlog of stale commands must not all go out once it recovers), and poll() writes
// them when it takes bytes again. Nothing is lost uncounted.
TEST_F(SerialLinkTest, AStalledDeviceGetsOnlyTheNewestFrames) {
  SerialLink link(
      {link_path, 115200, 0.02}, [](std::span<const std::uint8_t>) {}, [](bool) {});
  auto pty = std::make_unique<world_sim::PseudoTerminal>(link_path);
  link.start();
  ASSERT_TRUE(link.connected());
  // Nobody reads the controller's side: the pty fills, then frames queue and the oldest drop.
  const Bytes chunk(1024, 0x11);
  std::uint64_t sent = 0;
  for (int i = 0; i < 10'000 && link.stats().frames_dropped == 0; ++i) {
    ASSERT_TRUE(link.send(chunk));
    sent += chunk.size();
  }
  ASSERT_GT(link.stats().frames_dropped, 0u);
  const Bytes last{0x22, 0x23, 0x24};
  ASSERT_TRUE(link.send(last));
  sent += last.size();
  // The controller reads again: the queue goes out, the newest frame last.
  Bytes got;
  ASSERT_TRUE(runUntil(link, [&] {
    pty->read(got);
    return link.stats().bytes_out + link.stats().bytes_dropped == sent &&
           got.size() == link.stats().bytes_out;
  }));
  ASSERT_GE(got.size(), last.size());
  EXPECT_TRUE(std::equal(last.begin(), last.end(), got.end() - 3));
  EXPECT_LE(link.stats().bytes_dropped, link.stats().frames_dropped * chunk.size());
  link.stop();
}

}  // namespace serial_link_test
}  // namespace fieldline::motor_bridge
