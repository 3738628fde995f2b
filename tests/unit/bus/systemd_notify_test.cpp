// What a bus::Node tells systemd (common/bus/systemd_notify.hpp), received on a socket standing in
// for systemd's notification socket: READY=1 on the first loop, WATCHDOG=1 every half watchdog
// period of the loop's clock, the status state as STATUS=, nothing at all outside a unit. Each
// case runs in its own process (the notification state is process-wide, read once).
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "common/bus/node.hpp"

namespace fieldline::bus {
namespace systemd_notify_test {

// A datagram socket where systemd would listen (NOTIFY_SOCKET).
class FakeSystemd {
 public:
  FakeSystemd() {
    path_ = "/tmp/fieldline-notify-" + std::to_string(::getpid());
    ::unlink(path_.c_str());
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    path_.copy(address.sun_path, sizeof(address.sun_path) - 1);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
      ADD_FAILURE() << "cannot bind " << path_;
    }
  }
  ~FakeSystemd() {
    ::close(fd_);
    ::unlink(path_.c_str());
  }
  const std::string& path() const { return path_; }
  // Every message received so far.
  std::vector<std::string> take() {
    std::vector<std::string> out;
    char buffer[4096];
    for (ssize_t n; (n = ::recv(fd_, buffer, sizeof(buffer), 0)) > 0;)
      out.emplace_back(buffer, static_cast<std::size_t>(n));
    return out;
  }

 private:
  std::string path_;
  int fd_ = -1;
};

int count(const std::vector<std::string>& messages, const std::string& text) {
  int n = 0;
  for (const auto& m : messages)
    n += m == text ? 1 : 0;
  return n;
}

TEST(SystemdNotify, ReadyThenWatchdogFromTheLoopAndStatus) {
  FakeSystemd systemd;
  ::setenv("NOTIFY_SOCKET", systemd.path().c_str(), 1);
  ::setenv("WATCHDOG_USEC", "400000", 1);  // WatchdogSec=0.4s: a ping every 0.2 s
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);
  SimulatedClock clock;
  Node node{{.process = "camera", .robot_id = 1}, clock, Connection::open("memq://")};

  node.spinOnce(0);
  const std::vector<std::string> first = systemd.take();
  ASSERT_FALSE(first.empty());
  EXPECT_EQ(first.front(), "READY=1");
  EXPECT_EQ(count(first, "WATCHDOG=1"), 1);

  // The loop wakes in time for the next ping, and pings once per 0.2 s of its clock.
  EXPECT_LE(node.msUntilNextTimer(1000), 200);
  std::vector<std::string> later;
  for (int i = 0; i < 20; ++i) {  // 2 s in steps of 0.1 s
    clock.advance(100'000);
    node.spinOnce(0);
    // Read as systemd does: a datagram socket holds only a few unread messages.
    for (std::string& m : systemd.take())
      later.push_back(std::move(m));
  }
  EXPECT_EQ(count(later, "WATCHDOG=1"), 10);
  EXPECT_EQ(count(later, "READY=1"), 0);
  // SERVICE_STATUS once a second: its state for `systemctl status`.
  EXPECT_EQ(count(later, "STATUS=ok"), 2);

  // A loop that does not run sends nothing: systemd's watchdog then fires.
  clock.advance(5'000'000);
  EXPECT_TRUE(systemd.take().empty());
}

TEST(SystemdNotify, NoWatchdogForAnotherProcess) {
  FakeSystemd systemd;
  ::setenv("NOTIFY_SOCKET", systemd.path().c_str(), 1);
  ::setenv("WATCHDOG_USEC", "400000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid() + 1).c_str(), 1);  // a child's variables
  SimulatedClock clock;
  Node node{{.process = "camera", .robot_id = 1}, clock, Connection::open("memq://")};
  std::vector<std::string> messages;
  for (int i = 0; i < 10; ++i) {
    node.spinOnce(0);
    clock.advance(100'000);
    for (std::string& m : systemd.take())
      messages.push_back(std::move(m));
  }
  EXPECT_EQ(count(messages, "READY=1"), 1);
  EXPECT_EQ(count(messages, "WATCHDOG=1"), 0);
}

TEST(SystemdNotify, SilentOutsideAUnit) {
  FakeSystemd systemd;
  ::unsetenv("NOTIFY_SOCKET");
  ::setenv("WATCHDOG_USEC", "400000", 1);
  SimulatedClock clock;
  Node node{{.process = "camera", .robot_id = 1}, clock, Connection::open("memq://")};
  for (int i = 0; i < 30; ++i) {
    node.spinOnce(0);
    clock.advance(100'000);
  }
  EXPECT_TRUE(systemd.take().empty());
}

}  // namespace systemd_notify_test
}  // namespace fieldline::bus
