#include "common/time/clock.hpp"

#include <chrono>

namespace fieldline {

Utime SystemClock::now() const {
  using namespace std::chrono;
  return duration_cast<microseconds>(system_clock::now().time_since_epoch()).count();
}

Utime Clock::monotonicNow() const {
  using namespace std::chrono;
  return duration_cast<microseconds>(steady_clock::now().time_since_epoch()).count();
}

}  // namespace fieldline
