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

class Clock {
 public:
  virtual ~Clock() = default;
  // Current time, µs since the Unix epoch.
  virtual Utime now() const = 0;
};

// The real time of this machine (CLOCK_REALTIME, so stamps of different processes on one robot
// agree).
class SystemClock final : public Clock {
 public:
  Utime now() const override;
};

// Time that moves only when a test or a replay moves it. Thread-safe reads.
class SimulatedClock final : public Clock {
 public:
  explicit SimulatedClock(Utime start = 1'700'000'000'000'000) : now_(start) {}
  Utime now() const override { return now_.load(); }
  void set(Utime t) { now_.store(t); }
  void advance(Utime dt) { now_.fetch_add(dt); }

 private:
  std::atomic<Utime> now_;
};

}  // namespace fieldline
