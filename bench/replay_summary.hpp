// The replay benchmarks' one-line summary of per-message times (fieldline-replay-tracking,
// fieldline-replay-features).
#pragma once

#include <algorithm>
#include <cstdio>
#include <vector>

namespace fieldline::bench {

// "  what  median .. us  mean .. us  p90 .. us"; nothing for no samples.
inline void printReplaySummary(const char* what, std::vector<double> us) {
  if (us.empty()) return;
  std::sort(us.begin(), us.end());
  double sum = 0;
  for (const double x : us)
    sum += x;
  std::printf("  %-10s median %7.1f us  mean %7.1f us  p90 %7.1f us\n", what, us[us.size() / 2],
              sum / static_cast<double>(us.size()), us[us.size() * 9 / 10]);
}

}  // namespace fieldline::bench
