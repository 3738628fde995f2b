// The Boost.Asio serial link over a real pseudo-terminal: bytes both ways, and reconnection
// after the device disappears and returns (the emulator closing and reopening its pty).
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>

#include <gtest/gtest.h>
#include <boost/asio/io_context.hpp>

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

  // Runs the io_context until `done` holds; gives up after many rounds so a broken link fails
  // the test instead of hanging it (the assertion is on `done`, not on time).
  bool runUntil(boost::asio::io_context& io, const std::function<bool()>& done) {
    for (int round = 0; round < 2000 && !done(); ++round) {
      io.run_for(std::chrono::milliseconds(5));
      if (io.stopped()) io.restart();
    }
    return done();
  }

  std::filesystem::path dir;
  std::string link_path;
};

TEST_F(SerialLinkTest, CarriesBytesAndReconnectsAfterTheDeviceReturns) {
  boost::asio::io_context io;
  Bytes received;
  int ups = 0;
  int downs = 0;
  SerialLink link(
      io, {link_path, 115200, 0.02},
      [&](std::span<const std::uint8_t> b) { received.insert(received.end(), b.begin(), b.end()); },
      [&](bool up) { (up ? ups : downs)++; });

  // The device is not there yet: the link keeps trying.
  link.start();
  ASSERT_TRUE(runUntil(io, [&] { return link.stats().open_failures >= 2; }));
  EXPECT_FALSE(link.connected());
  EXPECT_FALSE(link.send(Bytes{1, 2, 3}));
  EXPECT_EQ(link.stats().bytes_dropped, 3u);

  auto pty = std::make_unique<world_sim::PseudoTerminal>(link_path);
  ASSERT_TRUE(runUntil(io, [&] { return link.connected(); }));
  EXPECT_EQ(ups, 1);

  // Emulator -> link, including zeros and CR/LF, unchanged.
  const Bytes down{0x00, 0x0a, 0x0d, 0x11, 0x13, 0xff};
  EXPECT_EQ(pty->write(down), 0u);
  ASSERT_TRUE(runUntil(io, [&] { return received.size() >= down.size(); }));
  EXPECT_EQ(received, down);
  // Link -> emulator.
  const Bytes up{0x7e, 0x00, 0x03};
  ASSERT_TRUE(link.send(up));
  Bytes got;
  ASSERT_TRUE(runUntil(io, [&] {
    pty->read(got);
    return got.size() >= up.size();
  }));
  EXPECT_EQ(got, up);

  // The device disappears: the link notices and reports it.
  pty.reset();
  ASSERT_TRUE(runUntil(io, [&] { return downs == 1; }));
  EXPECT_FALSE(link.connected());
  EXPECT_EQ(link.stats().disconnects, 1u);

  // ... and returns under the same name (a new pty number behind the link): reconnected.
  pty = std::make_unique<world_sim::PseudoTerminal>(link_path);
  ASSERT_TRUE(runUntil(io, [&] { return link.connected(); }));
  EXPECT_EQ(ups, 2);
  received.clear();
  EXPECT_EQ(pty->write(Bytes{0x42}), 0u);
  ASSERT_TRUE(runUntil(io, [&] { return !received.empty(); }));
  EXPECT_EQ(received, Bytes{0x42});
  ASSERT_TRUE(link.send(Bytes{0x43}));
  got.clear();
  ASSERT_TRUE(runUntil(io, [&] {
    pty->read(got);
    return !got.empty();
  }));
  EXPECT_EQ(got, Bytes{0x43});
  link.stop();
}

// After a stall of the bridge the pty holds a backlog of frames; the link hands it over in one
// piece, so the bridge can stamp each sample by its controller time relative to the newest.
TEST_F(SerialLinkTest, ABacklogArrivesInOneRead) {
  boost::asio::io_context io;
  std::vector<std::size_t> reads;
  SerialLink link(
      io, {link_path, 115200, 0.02},
      [&](std::span<const std::uint8_t> b) { reads.push_back(b.size()); }, [](bool) {});
  auto pty = std::make_unique<world_sim::PseudoTerminal>(link_path);
  link.start();
  ASSERT_TRUE(runUntil(io, [&] { return link.connected(); }));
  // 0.7 s of 50 Hz odometry frames (about 40 bytes each), written while the link is not read.
  const Bytes backlog(35 * 40, 0x5a);
  ASSERT_EQ(pty->write(backlog), 0u);
  ASSERT_TRUE(runUntil(io, [&] { return !reads.empty(); }));
  EXPECT_EQ(reads.front(), backlog.size());
  link.stop();
}

}  // namespace serial_link_test
}  // namespace fieldline::motor_bridge
