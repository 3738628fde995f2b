// Where nodes get "now" from. Algorithms never read a clock; nodes are handed one, so tests and
// replays can step time by hand.
#pragma once

#include <atomic>
#include <cstdint>

namespace fieldline {

// Microseconds since the Unix epoch, the unit of every utime in the project.
using Utime = std::int64_t;

inline constexpr Utime kMicrosPerSecond = 1'000'000;
inline constexpr Utime kMicrosPerMilli = 1'000;

// Two readings: now() stamps messages (wall or robot time, may step when the clock is set, e.g.
// by time sync on a robot); monotonicNow() measures elapsed time for timers and timeouts and
// never steps. Only differences of monotonicNow() mean anything.
class Clock {
 public:
  virtual ~Clock() = default;
  // Current time, µs since the Unix epoch.
  virtual Utime now() const = 0;
  // Elapsed time, µs since an arbitrary origin; never goes backwards. By default
  // std::chrono::steady_clock, right for every clock that runs in real time (also one with a
  // robot's offset and drift).
  virtual Utime monotonicNow() const;
};

// The real time of this machine: now() is CLOCK_REALTIME (so stamps of different processes on
// one robot agree), monotonicNow() is std::chrono::steady_clock.
class SystemClock final : public Clock {
 public:
  Utime now() const override;
};

// Time that moves only when a test or a replay moves it. Thread-safe reads.
//   advance(dt): dt elapses (both readings move).
//   set(t):      jump to t; moving forward counts as elapsed time (replays set log times),
//                moving backward is a clock step that elapses nothing.
//   step(dt):    a step of the wall time alone, either way (what time sync does to a robot).
class SimulatedClock final : public Clock {
 public:
  explicit SimulatedClock(Utime start = 1'700'000'000'000'000) : now_(start), elapsed_(0) {}
  Utime now() const override { return now_.load(); }
  Utime monotonicNow() const override { return elapsed_.load(); }
  void set(Utime t) {
    const Utime before = now_.exchange(t);
    if (t > before) elapsed_.fetch_add(t - before);
  }
  void advance(Utime dt) {
    now_.fetch_add(dt);
    if (dt > 0) elapsed_.fetch_add(dt);
  }
  void step(Utime dt) { now_.fetch_add(dt); }

 private:
  std::atomic<Utime> now_;
  std::atomic<Utime> elapsed_;
};

}  // namespace fieldline
