// A time-indexed channel (seed 4.7): a bounded ring buffer of samples ordered by utime, found by
// binary search, with interpolation between neighbours. Samples that would break the order, are
// older than the history or lie too far in the future are rejected and counted, never stored.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>

#include <boost/circular_buffer.hpp>

#include "common/time/clock.hpp"

namespace fieldline {

struct TimedChannelLimits {
  // Samples kept; the oldest is dropped when a new one arrives in a full buffer.
  std::size_t capacity = 100;
  // Samples older than newest - max_age_us are rejected as too old (0: only the capacity limits).
  Utime max_age_us = 0;
  // Samples newer than now + future_tolerance_us are rejected as from the future.
  Utime future_tolerance_us = 200'000;
  // When true a late sample is inserted at its place (if still inside the history); when false any
  // sample older than the newest is rejected as out of order.
  bool insert_late = false;
};

enum class InsertResult { kAccepted, kOutOfOrder, kTooOld, kFromFuture, kDuplicate };

const char* toString(InsertResult r);

struct TimedChannelCounters {
  std::uint64_t accepted = 0;
  std::uint64_t out_of_order = 0;
  std::uint64_t too_old = 0;
  std::uint64_t from_future = 0;
  std::uint64_t duplicate = 0;
  std::uint64_t evicted = 0;  // pushed out by capacity
};

// Linear interpolation a + (b - a) * w for anything with + and scalar *.
struct LinearInterpolation {
  template <typename T>
  T operator()(const T& a, const T& b, double w) const {
    return a + (b - a) * w;
  }
};

template <typename T>
struct TimedSample {
  Utime utime;
  T value;
};

template <typename T, typename Interpolate = LinearInterpolation>
class TimedChannel {
 public:
  using Sample = TimedSample<T>;

  explicit TimedChannel(TimedChannelLimits limits = {})
      : limits_(limits), buffer_(limits.capacity) {
    if (limits.capacity == 0) throw std::invalid_argument("TimedChannel capacity must be > 0");
  }

  // Stores `value` observed at `utime`, given the current time `now`.
  InsertResult insert(Utime utime, const T& value, Utime now) {
    const InsertResult r = check(utime, now);
    if (r != InsertResult::kAccepted) {
      count(r);
      return r;
    }
    if (buffer_.full()) ++counters_.evicted;
    if (buffer_.empty() || utime > buffer_.back().utime) {
      buffer_.push_back(Sample{utime, value});
    } else {
      // Late sample inside the history: keep the order. A full buffer drops its oldest first.
      if (buffer_.full()) buffer_.pop_front();
      buffer_.insert(lowerBound(utime), Sample{utime, value});
    }
    ++counters_.accepted;
    return InsertResult::kAccepted;
  }

  std::size_t size() const { return buffer_.size(); }
  bool empty() const { return buffer_.empty(); }
  void clear() { buffer_.clear(); }
  // Applies `f` to every stored value in place; times and order stay (e.g. a change of frame).
  template <class F>
  void transformValues(F&& f) {
    for (Sample& sample : buffer_)
      f(sample.value);
  }
  const Sample& operator[](std::size_t i) const { return buffer_[i]; }
  const Sample& oldest() const { return buffer_.front(); }
  const Sample& newest() const { return buffer_.back(); }
  const TimedChannelCounters& counters() const { return counters_; }
  const TimedChannelLimits& limits() const { return limits_; }

  // Index of the first sample with utime >= t (size() if none), by binary search.
  std::size_t indexAtOrAfter(Utime t) const {
    return static_cast<std::size_t>(lowerBoundConst(t) - buffer_.begin());
  }

  // The samples enclosing t: before.utime <= t <= after.utime. Empty outside the history.
  struct Bracket {
    const Sample* before;
    const Sample* after;
  };
  std::optional<Bracket> around(Utime t) const {
    if (buffer_.empty() || t < buffer_.front().utime || t > buffer_.back().utime) return {};
    const std::size_t i = indexAtOrAfter(t);
    const Sample& after = buffer_[i];
    if (after.utime == t) return Bracket{&after, &after};
    return Bracket{&buffer_[i - 1], &after};
  }

  // The value at time t interpolated between its neighbours; empty outside the history
  // (no extrapolation: the caller decides what a missing value means).
  std::optional<T> at(Utime t) const {
    const auto b = around(t);
    if (!b) return {};
    if (b->before == b->after) return b->before->value;
    const double w = static_cast<double>(t - b->before->utime) /
                     static_cast<double>(b->after->utime - b->before->utime);
    return Interpolate{}(b->before->value, b->after->value, w);
  }

  // The sample nearest in time to t, if any.
  const Sample* nearest(Utime t) const {
    if (buffer_.empty()) return nullptr;
    const std::size_t i = indexAtOrAfter(t);
    if (i == 0) return &buffer_.front();
    if (i == buffer_.size()) return &buffer_.back();
    const Sample& a = buffer_[i - 1];
    const Sample& b = buffer_[i];
    return (t - a.utime <= b.utime - t) ? &a : &b;
  }

  // Drops every sample older than t.
  void dropBefore(Utime t) {
    while (!buffer_.empty() && buffer_.front().utime < t)
      buffer_.pop_front();
  }

 private:
  InsertResult check(Utime utime, Utime now) const {
    if (utime > now + limits_.future_tolerance_us) return InsertResult::kFromFuture;
    if (buffer_.empty()) return InsertResult::kAccepted;
    const Utime newest = buffer_.back().utime;
    if (limits_.max_age_us > 0 && utime < newest - limits_.max_age_us) return InsertResult::kTooOld;
    if (utime > newest) return InsertResult::kAccepted;
    if (!limits_.insert_late) {
      return utime == newest ? InsertResult::kDuplicate : InsertResult::kOutOfOrder;
    }
    if (buffer_.full() && utime <= buffer_.front().utime) return InsertResult::kTooOld;
    const auto it = lowerBoundConst(utime);
    if (it != buffer_.end() && it->utime == utime) return InsertResult::kDuplicate;
    return InsertResult::kAccepted;
  }

  void count(InsertResult r) {
    switch (r) {
      case InsertResult::kOutOfOrder:
        ++counters_.out_of_order;
        break;
      case InsertResult::kTooOld:
        ++counters_.too_old;
        break;
      case InsertResult::kFromFuture:
        ++counters_.from_future;
        break;
      case InsertResult::kDuplicate:
        ++counters_.duplicate;
        break;
      case InsertResult::kAccepted:
        break;
    }
  }

  using Buffer = boost::circular_buffer<Sample>;
  typename Buffer::iterator lowerBound(Utime t) {
    return std::lower_bound(buffer_.begin(), buffer_.end(), t,
                            [](const Sample& s, Utime v) { return s.utime < v; });
  }
  typename Buffer::const_iterator lowerBoundConst(Utime t) const {
    return std::lower_bound(buffer_.begin(), buffer_.end(), t,
                            [](const Sample& s, Utime v) { return s.utime < v; });
  }

  TimedChannelLimits limits_;
  Buffer buffer_;
  TimedChannelCounters counters_;
};

}  // namespace fieldline
