#include "tools/launch/backoff.hpp"

#include <algorithm>
#include <cmath>

namespace fieldline::launch {

double RestartBackoff::delayAfterExit(double run_s) {
  if (!(run_s < params_.stable_s)) failures_ = 0;
  // Doubling stops at the ceiling; capping the exponent keeps pow() finite for long crash loops.
  const int doublings = std::min(failures_, 60);
  ++failures_;
  return std::min(params_.initial_s * std::pow(2.0, doublings), params_.max_s);
}

}  // namespace fieldline::launch
