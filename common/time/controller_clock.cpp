#include "common/time/controller_clock.hpp"

#include <algorithm>

namespace fieldline {

void ControllerClockMap::reset() {
  window_.clear();
  last_device_.reset();
  last_receive_ = 0;
  high_since_.reset();
}

void ControllerClockMap::restart(std::int64_t device_us, std::int64_t offset, Utime receive_us) {
  if (last_device_) ++restarts_;
  window_.clear();
  window_.push_back({device_us, offset, receive_us});
  high_since_.reset();
}

void ControllerClockMap::observe(std::int64_t device_us, Utime receive_us) {
  const std::int64_t offset = receive_us - device_us;
  if (!last_device_ || window_.empty()) {
    restart(device_us, offset, receive_us);
  } else if (device_us < *last_device_ ||
             (device_us - *last_device_) - (receive_us - last_receive_) >
                 params_.max_device_jump_us) {
    // The device restarted (its clock ran backwards, or leapt ahead of the host's).
    restart(device_us, offset, receive_us);
  } else {
    if (offset > window_.front().offset + params_.step_us) {
      if (!high_since_) {
        high_since_ = receive_us;
        high_min_ = offset;
      }
      high_min_ = std::min(high_min_, offset);
      if (receive_us - *high_since_ >= params_.confirm_us) {
        // The host clock stepped forward: every sample for a while came "late" by it.
        restart(device_us, high_min_, receive_us);
        last_device_ = device_us;
        last_receive_ = receive_us;
        return;
      }
    } else {
      high_since_.reset();
    }
    while (!window_.empty() && window_.back().offset >= offset)
      window_.pop_back();
    window_.push_back({device_us, offset, receive_us});
    // Only an entry read before this read may take the place of an aged-out front: the
    // samples of one late read carry the stall in their offsets (but the newest's).
    while (window_.size() > 1 && window_.front().device_us < device_us - params_.window_us &&
           window_[1].receive_us < receive_us)
      window_.pop_front();
  }
  last_device_ = device_us;
  last_receive_ = receive_us;
}

std::optional<std::int64_t> ControllerClockMap::envelope() const {
  if (window_.empty()) return std::nullopt;
  return window_.front().offset;
}

std::optional<Utime> ControllerClockMap::stamp(std::int64_t device_us) const {
  const auto e = envelope();
  if (!e) return std::nullopt;
  return device_us + *e - params_.latency_us;
}

}  // namespace fieldline
