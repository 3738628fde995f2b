// Exponential restart backoff: a process that keeps crashing is restarted after 0.5 s, 1 s, 2 s,
// ... up to a ceiling; a process that ran long enough to count as stable starts over at the
// shortest delay. Plain arithmetic on durations, no clock.
#pragma once

#include "tools/launch/launch_file.hpp"

namespace fieldline::launch {

class RestartBackoff {
 public:
  explicit RestartBackoff(BackoffParams params = {}) : params_(params) {}

  // The process ran for `run_s` seconds and ended: returns how long to wait before restarting
  // it, s. Counts this crash.
  double delayAfterExit(double run_s);

  // Crashes counted since the last stable run.
  int consecutiveFailures() const { return failures_; }
  const BackoffParams& params() const { return params_; }

 private:
  BackoffParams params_;
  int failures_ = 0;
};

}  // namespace fieldline::launch
