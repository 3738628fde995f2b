// The node's event loop: watched file descriptors next to LCM's, timers on monotonic time that
// a step of the wall clock neither stalls nor bursts, and the wait until the next timer.
#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"

namespace fieldline::bus {
namespace event_loop_test {

constexpr Utime kHourUs = 3600 * kMicrosPerSecond;

// A pipe whose read end a node watches.
struct Pipe {
  std::array<int, 2> fds{-1, -1};
  Pipe() {
    if (::pipe2(fds.data(), O_NONBLOCK) != 0) throw std::runtime_error("pipe2 failed");
  }
  ~Pipe() {
    for (int fd : fds)
      if (fd >= 0) ::close(fd);
  }
  int readEnd() const { return fds[0]; }
  void put(char c) { ASSERT_EQ(::write(fds[1], &c, 1), 1); }
  int drain() {
    char buf[64];
    int total = 0;
    for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;)
      total += static_cast<int>(n);
    return total;
  }
};

class EventLoopTest : public ::testing::Test {
 protected:
  SimulatedClock clock{1'800'000'000'000'000};
  Node node{{.process = "loop", .robot_id = 1, .status_period_us = 0},
            clock,
            Connection::open("memq://")};
};

TEST_F(EventLoopTest, WatchedFdCallbackFiresWhenReadable) {
  Pipe pipe;
  int calls = 0;
  int bytes = 0;
  const auto id = node.watchFd(pipe.readEnd(), [&] {
    ++calls;
    bytes += pipe.drain();
  });
  node.spinOnce(0);
  EXPECT_EQ(calls, 0);  // nothing written yet
  pipe.put('a');
  pipe.put('b');
  node.spinOnce(1000);  // returns as soon as the pipe is readable
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(bytes, 2);
  node.spinOnce(0);
  EXPECT_EQ(calls, 1);  // drained: no further calls

  node.unwatchFd(id);
  EXPECT_EQ(node.watchedFdCount(), 0u);
  pipe.put('c');
  node.spinOnce(0);
  EXPECT_EQ(calls, 1);
}

TEST_F(EventLoopTest, CallbackMayUnwatchItselfAndOthers) {
  Pipe first;
  Pipe second;
  int first_calls = 0;
  int second_calls = 0;
  Node::WatchId second_id = 0;
  Node::WatchId first_id = 0;
  first_id = node.watchFd(first.readEnd(), [&] {
    ++first_calls;
    first.drain();
    node.unwatchFd(first_id);
    node.unwatchFd(second_id);
  });
  second_id = node.watchFd(second.readEnd(), [&] { ++second_calls; });
  first.put('x');
  second.put('y');
  node.spinOnce(0);
  EXPECT_EQ(first_calls, 1);
  EXPECT_EQ(second_calls, 0);  // removed before its turn in the same spin
  EXPECT_EQ(node.watchedFdCount(), 0u);
}

TEST_F(EventLoopTest, ClosedFdIsDroppedAndCounted) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  ::close(fds[0]);
  ::close(fds[1]);
  int calls = 0;
  node.watchFd(fds[0], [&] { ++calls; });
  node.spinOnce(0);
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(node.watchedFdCount(), 0u);
  EXPECT_EQ(node.status().errorCount("watch_fd"), 1);
  EXPECT_THROW(node.watchFd(-1, [] {}), std::invalid_argument);
}

TEST_F(EventLoopTest, WaitEndsAtTheNextTimer) {
  node.every(20 * kMicrosPerMilli, [] {});
  EXPECT_EQ(node.msUntilNextTimer(100), 20);
  clock.advance(15 * kMicrosPerMilli);
  EXPECT_EQ(node.msUntilNextTimer(100), 5);
  clock.advance(5 * kMicrosPerMilli);
  EXPECT_EQ(node.msUntilNextTimer(100), 0);
  node.spinOnce(0);
  EXPECT_EQ(node.msUntilNextTimer(100), 20);
  EXPECT_EQ(node.msUntilNextTimer(7), 7);
}

TEST_F(EventLoopTest, ClockStepBackByAnHourDoesNotStallTimers) {
  int ticks = 0;
  int once = 0;
  node.every(10 * kMicrosPerMilli, [&] { ++ticks; });
  node.at(clock.now() + 50 * kMicrosPerMilli, [&] { ++once; });
  for (int i = 0; i < 3; ++i) {
    clock.advance(10 * kMicrosPerMilli);
    node.spinOnce(0);
  }
  EXPECT_EQ(ticks, 3);
  clock.step(-kHourUs);  // time sync sets the robot's clock back
  for (int i = 0; i < 3; ++i) {
    clock.advance(10 * kMicrosPerMilli);
    node.spinOnce(0);
  }
  EXPECT_EQ(ticks, 6);
  EXPECT_EQ(once, 1);  // its 50 ms elapsed, whatever the wall clock says
  // A step forward fires nothing early and bursts nothing.
  clock.step(2 * kHourUs);
  node.spinOnce(0);
  EXPECT_EQ(ticks, 6);
  clock.advance(10 * kMicrosPerMilli);
  node.spinOnce(0);
  EXPECT_EQ(ticks, 7);
}

// after(): a one-shot deadline on elapsed time that its callback may set again (the team link's
// next packet), each firing once, never early, and unmoved by a step of the wall clock.
TEST_F(EventLoopTest, OneShotDeadlineFiresOnceAndMaySetTheNext) {
  std::vector<Utime> fired;
  std::function<void()> onDeadline = [&] {
    fired.push_back(clock.monotonicNow());
    if (fired.size() < 3) node.after(30 * kMicrosPerMilli, onDeadline);
  };
  const Utime start = clock.monotonicNow();
  node.after(20 * kMicrosPerMilli, onDeadline);
  EXPECT_EQ(node.msUntilNextTimer(100), 20);
  clock.advance(19 * kMicrosPerMilli);
  node.spinOnce(0);
  EXPECT_TRUE(fired.empty());
  clock.step(-kHourUs);
  clock.advance(1 * kMicrosPerMilli);
  node.spinOnce(0);
  ASSERT_EQ(fired.size(), 1u);
  EXPECT_EQ(fired[0] - start, 20 * kMicrosPerMilli);
  EXPECT_EQ(node.msUntilNextTimer(100), 30);
  for (int i = 0; i < 100; ++i) {
    clock.advance(1 * kMicrosPerMilli);
    node.spinOnce(0);
  }
  ASSERT_EQ(fired.size(), 3u);
  EXPECT_EQ(fired[1] - start, 50 * kMicrosPerMilli);
  EXPECT_EQ(fired[2] - start, 80 * kMicrosPerMilli);
  // Nothing left to wait for.
  EXPECT_EQ(node.msUntilNextTimer(100), 100);
  EXPECT_THROW(node.after(-1, [] {}), std::invalid_argument);
}

// moveTimer(): a periodic tick moved to an event that does its work (the motor bridge's command
// tick at the controller's sample) goes on every period from there, fires nothing early and
// nothing twice; moved from inside its own callback or another's, and not for an id gone.
TEST_F(EventLoopTest, MovedTimerGoesOnEveryPeriodFromItsNewTime) {
  const Utime start = clock.monotonicNow();
  std::vector<Utime> ticks;
  const Node::TimerId tick =
      node.every(20 * kMicrosPerMilli, [&] { ticks.push_back(clock.monotonicNow() - start); });
  const auto spinFor = [&](Utime us) {
    for (Utime t = 0; t < us; t += kMicrosPerMilli) {
      clock.advance(kMicrosPerMilli);
      node.spinOnce(0);
    }
  };
  spinFor(25 * kMicrosPerMilli);
  ASSERT_EQ(ticks.size(), 1u);
  EXPECT_EQ(ticks[0], 20 * kMicrosPerMilli);
  // At 25 ms the tick (due at 40) is done by the event: moved to 25 + 20 + 5.
  EXPECT_TRUE(node.moveTimer(tick, 25 * kMicrosPerMilli));
  EXPECT_EQ(node.msUntilNextTimer(100), 25);
  spinFor(24 * kMicrosPerMilli);  // to 49 ms: the tick once due at 40 does not fire
  EXPECT_EQ(ticks.size(), 1u);
  spinFor(1 * kMicrosPerMilli);
  ASSERT_EQ(ticks.size(), 2u);
  EXPECT_EQ(ticks[1], 50 * kMicrosPerMilli);
  spinFor(19 * kMicrosPerMilli);
  EXPECT_EQ(ticks.size(), 2u);
  spinFor(1 * kMicrosPerMilli);  // every period from 50 on
  ASSERT_EQ(ticks.size(), 3u);
  EXPECT_EQ(ticks[2], 70 * kMicrosPerMilli);
  // Moved to now: fires at the next spin, once, and the period goes on from there.
  spinFor(5 * kMicrosPerMilli);
  EXPECT_TRUE(node.moveTimer(tick, 0));
  EXPECT_EQ(node.msUntilNextTimer(100), 0);
  node.spinOnce(0);
  ASSERT_EQ(ticks.size(), 4u);
  EXPECT_EQ(ticks[3], 75 * kMicrosPerMilli);
  node.spinOnce(0);
  EXPECT_EQ(ticks.size(), 4u);
  EXPECT_EQ(node.msUntilNextTimer(100), 20);
  EXPECT_THROW(node.moveTimer(tick, -1), std::invalid_argument);
  EXPECT_FALSE(node.moveTimer(tick + 100, 0));
}

TEST_F(EventLoopTest, ATimerMayMoveItselfAndAnotherFromItsCallback) {
  const Utime start = clock.monotonicNow();
  std::vector<Utime> a_ticks, b_ticks;
  Node::TimerId a = 0, b = 0;
  // a moves itself 5 ms later each time; b is held back by a whenever a fires.
  a = node.every(10 * kMicrosPerMilli, [&] {
    a_ticks.push_back(clock.monotonicNow() - start);
    EXPECT_TRUE(node.moveTimer(a, 15 * kMicrosPerMilli));
    EXPECT_TRUE(node.moveTimer(b, 30 * kMicrosPerMilli));
  });
  b = node.every(20 * kMicrosPerMilli, [&] { b_ticks.push_back(clock.monotonicNow() - start); });
  for (int i = 0; i < 60; ++i) {
    clock.advance(kMicrosPerMilli);
    node.spinOnce(0);
  }
  EXPECT_EQ(a_ticks, (std::vector<Utime>{10'000, 25'000, 40'000, 55'000}));
  EXPECT_TRUE(b_ticks.empty());
  // A one-shot that fired is gone.
  const Node::TimerId once = node.after(0, [] {});
  node.spinOnce(0);
  EXPECT_FALSE(node.moveTimer(once, 10));
}

TEST_F(EventLoopTest, ACancelledTimerNeverFiresAgain) {
  int a_ticks = 0, b_ticks = 0, c_ticks = 0;
  Node::TimerId b = 0;
  // a and b are due in the same round; a cancels b first; c is cancelled from outside.
  node.every(10 * kMicrosPerMilli, [&] {
    ++a_ticks;
    node.cancelTimer(b);
  });
  b = node.every(10 * kMicrosPerMilli, [&] { ++b_ticks; });
  const Node::TimerId c = node.after(5 * kMicrosPerMilli, [&] { ++c_ticks; });
  EXPECT_EQ(node.msUntilNextTimer(100), 5);
  EXPECT_TRUE(node.cancelTimer(c));
  EXPECT_FALSE(node.cancelTimer(c));
  EXPECT_EQ(node.msUntilNextTimer(100), 10);
  for (int i = 0; i < 35; ++i) {
    clock.advance(kMicrosPerMilli);
    node.spinOnce(0);
  }
  EXPECT_EQ(a_ticks, 3);
  EXPECT_EQ(b_ticks, 0);
  EXPECT_EQ(c_ticks, 0);
  EXPECT_FALSE(node.cancelTimer(b));
  EXPECT_FALSE(node.moveTimer(b, 0));
}

// Real time whose wall reading can be stepped, like a robot's clock under time sync; its
// monotonic reading is the machine's steady clock.
class SteppableSystemClock final : public Clock {
 public:
  Utime now() const override { return system_.now() + offset_.load(); }
  void step(Utime dt) { offset_ += dt; }

 private:
  SystemClock system_;
  std::atomic<Utime> offset_{0};
};

TEST(EventLoopRealTime, StepOfTheWallClockDoesNotStallTheLoop) {
  SteppableSystemClock clock;
  Node node{{.process = "loop", .robot_id = 1, .status_period_us = 0},
            clock,
            Connection::open("memq://")};
  int ticks = 0;
  node.every(2 * kMicrosPerMilli, [&] { ++ticks; });
  auto spinUntil = [&](int target) {
    // Bounded in rounds, not in time: a stalled timer fails the test instead of hanging it.
    for (int round = 0; round < 5000 && ticks < target; ++round)
      node.spinOnce(node.msUntilNextTimer(50));
    return ticks >= target;
  };
  ASSERT_TRUE(spinUntil(3));
  clock.step(-kHourUs);
  const int before = ticks;
  EXPECT_TRUE(spinUntil(before + 5));
}

}  // namespace event_loop_test
}  // namespace fieldline::bus
