#include "services/fusion/history.hpp"

#include <algorithm>
#include <limits>

namespace fieldline::fusion {
namespace {

constexpr int kOdometryKind = 0;
// Pose measurements of source s have kind 1 + s: at equal times odometry goes first, then
// lines, then features.
int kindOf(MeasurementSource s) {
  return 1 + static_cast<int>(s);
}

TimedChannelLimits channelLimits(std::size_t capacity) {
  TimedChannelLimits limits;
  limits.capacity = capacity;
  limits.insert_late = true;
  // The filter checks age and future itself, against its own newest input.
  limits.max_age_us = 0;
  limits.future_tolerance_us = std::numeric_limits<Utime>::max() / 4;
  return limits;
}

bool finite(const geometry::Pose2& p) {
  return geometry::isFinite(p);
}

}  // namespace

const char* toString(Rejection r) {
  switch (r) {
    case Rejection::kNone:
      return "none";
    case Rejection::kFromFuture:
      return "from_future";
    case Rejection::kTooOld:
      return "too_old";
    case Rejection::kNotFinite:
      return "not_finite";
    case Rejection::kNotPositiveDefinite:
      return "covariance_not_positive_definite";
    case Rejection::kDuplicate:
      return "duplicate";
    case Rejection::kGated:
      return "gated";
    case Rejection::kNotInitialized:
      return "not_initialized";
    case Rejection::kCount:
      break;
  }
  return "unknown";
}

DelayedFilter::DelayedFilter(FilterParams params)
    : params_(params),
      // 50 Hz odometry and up to 30 Hz vision over the window, with room to spare.
      odometry_(channelLimits(static_cast<std::size_t>(
          std::max<Utime>(64, 4 * 50 * params.window_us / kMicrosPerSecond)))),
      measurements_{TimedChannel<PoseMeasurement>(channelLimits(static_cast<std::size_t>(
                        std::max<Utime>(32, 4 * 30 * params.window_us / kMicrosPerSecond)))),
                    TimedChannel<PoseMeasurement>(channelLimits(static_cast<std::size_t>(
                        std::max<Utime>(32, 4 * 30 * params.window_us / kMicrosPerSecond))))} {}

void DelayedFilter::initialize(const EkfState& state) {
  checkpoints_.clear();
  checkpoints_.push_back(state);
  newest_input_ = std::max(newest_input_, state.utime);
  odometry_.dropBefore(state.utime + 1);
  for (auto& channel : measurements_)
    channel.dropBefore(state.utime + 1);
  replayFrom(state.utime + 1, -1);
  prune();
}

void DelayedFilter::mirrorThroughCentre() {
  for (EkfState& s : checkpoints_)
    s = pointMirrored(s);
  for (auto& channel : measurements_)
    channel.transformValues([](PoseMeasurement& z) { z = pointMirrored(z); });
}

Rejection DelayedFilter::checkTime(Utime utime, Utime now) const {
  if (utime > now + params_.future_tolerance_us) return Rejection::kFromFuture;
  if (newest_input_ > 0 && utime < newest_input_ - params_.window_us) return Rejection::kTooOld;
  if (initialized() && utime <= checkpoints_.front().utime) return Rejection::kTooOld;
  return Rejection::kNone;
}

Rejection DelayedFilter::addOdometry(const OdometryStep& step, Utime now) {
  if (!step.integrated.allFinite() || !step.covariance.allFinite() || step.t_end <= step.t_start) {
    return count(Rejection::kNotFinite);
  }
  if (const Rejection r = checkTime(step.t_end, now); r != Rejection::kNone) return count(r);
  if (odometry_.insert(step.t_end, step, now) != InsertResult::kAccepted) {
    return count(Rejection::kDuplicate);
  }
  newest_input_ = std::max(newest_input_, step.t_end);
  // From the step's start: a measurement inside its interval was carried there without it.
  if (initialized()) replayFrom(std::max(step.t_start, checkpoints_.front().utime) + 1, -1);
  prune();
  return Rejection::kNone;
}

DelayedFilter::PoseResult DelayedFilter::addPose(MeasurementSource source, const PoseMeasurement& z,
                                                 Utime now) {
  PoseResult result;
  if (!finite(z.pose) || !z.covariance.allFinite()) {
    result.rejection = count(Rejection::kNotFinite);
    return result;
  }
  if (!isPositiveDefinite(z.covariance)) {
    result.rejection = count(Rejection::kNotPositiveDefinite);
    return result;
  }
  if (const Rejection r = checkTime(z.utime, now); r != Rejection::kNone) {
    result.rejection = count(r);
    return result;
  }
  auto& channel = measurements_[static_cast<std::size_t>(source)];
  if (channel.insert(z.utime, z, now) != InsertResult::kAccepted) {
    result.rejection = count(Rejection::kDuplicate);
    return result;
  }
  newest_input_ = std::max(newest_input_, z.utime);
  if (!initialized()) {
    // Kept: a later initialize() replays it.
    result.rejection = count(Rejection::kNotInitialized);
    prune();
    return result;
  }
  const Applied applied = replayFrom(z.utime, kindOf(source));
  result.update = applied.update;
  if (!applied.update.accepted) result.rejection = count(Rejection::kGated);
  prune();
  return result;
}

Rejection DelayedFilter::addContact(Utime utime, Utime now) {
  if (const Rejection r = checkTime(utime, now); r != Rejection::kNone) return count(r);
  const auto it = std::lower_bound(contacts_.begin(), contacts_.end(), utime);
  if (it != contacts_.end() && *it == utime) return count(Rejection::kDuplicate);
  contacts_.insert(it, utime);
  newest_input_ = std::max(newest_input_, utime);
  if (initialized() && params_.contact.hold_us > 0) replayFrom(utime, -1);
  prune();
  return Rejection::kNone;
}

bool DelayedFilter::inContact(Utime t) const {
  // The newest evidence at or before t.
  auto it = std::upper_bound(contacts_.begin(), contacts_.end(), t);
  if (it == contacts_.begin()) return false;
  return t - *std::prev(it) <= params_.contact.hold_us;
}

double DelayedFilter::contactSeconds(Utime a, Utime b) const {
  const Utime hold = params_.contact.hold_us;
  if (b <= a || hold <= 0 || contacts_.empty()) return 0.0;
  // The union of [e, e + hold] over the evidence e, intersected with [a, b].
  auto it = std::lower_bound(contacts_.begin(), contacts_.end(), a - hold);
  Utime covered = 0;
  Utime reach = a;  // everything before `reach` is counted already
  for (; it != contacts_.end() && *it < b; ++it) {
    const Utime from = std::max(*it, reach);
    const Utime to = std::min(*it + hold, b);
    if (to > from) {
      covered += to - from;
      reach = to;
    }
  }
  return static_cast<double>(covered) * 1e-6;
}

void DelayedFilter::addUnseen(EkfState& s, Utime a, Utime b) const {
  if (b <= a) return;
  const ContactModel& c = params_.contact;
  // The gyro sees the twist of a contact; the wheels do not.
  const double heading = s.gyro ? c.gyro_heading_density : c.heading_density;
  const bool push = params_.push.density > 0.0;
  if (c.position_density <= 0.0 && heading <= 0.0 && !push) return;
  const double dt = contactSeconds(a, b);
  if (push) predictPush(s, static_cast<double>(b - a) * 1e-6, dt, params_.push);
  if (dt <= 0.0) return;
  s.p(0, 0) += c.position_density * c.position_density * dt;
  s.p(1, 1) += c.position_density * c.position_density * dt;
  s.p(2, 2) += heading * heading * dt;
}

void DelayedFilter::carryTo(EkfState& s, Utime t) const {
  if (t <= s.utime) return;
  const Utime from = s.utime;
  // The odometry step whose interval holds t (the first one ending after it), when stored.
  const std::size_t i = odometry_.indexAtOrAfter(t + 1);
  if (i < odometry_.size() && odometry_[i].value.t_start < t) {
    predictOdometryPart(s, odometry_[i].value, t, params_.noise);
  } else {
    predictConstantVelocity(s, t, params_.noise);
  }
  addUnseen(s, from, s.utime);
}

DelayedFilter::Applied DelayedFilter::replayFrom(Utime t, int target_kind) {
  Applied applied;
  if (!initialized()) return applied;
  // The last checkpoint strictly before t: everything at t and after is processed again.
  auto it = std::lower_bound(checkpoints_.begin(), checkpoints_.end(), t,
                             [](const EkfState& s, Utime v) { return s.utime < v; });
  if (it == checkpoints_.begin()) return applied;  // before the base: refused by checkTime
  --it;
  if (std::next(it) != checkpoints_.end()) ++replays_;
  checkpoints_.erase(std::next(it), checkpoints_.end());
  EkfState state = checkpoints_.back();
  const Utime t0 = state.utime;

  std::size_t io = odometry_.indexAtOrAfter(t0 + 1);
  std::array<std::size_t, 2> im{measurements_[0].indexAtOrAfter(t0 + 1),
                                measurements_[1].indexAtOrAfter(t0 + 1)};
  for (;;) {
    // The next input by (utime, kind).
    int kind = -1;
    Utime next = std::numeric_limits<Utime>::max();
    if (io < odometry_.size()) {
      next = odometry_[io].utime;
      kind = kOdometryKind;
    }
    for (std::size_t m = 0; m < 2; ++m) {
      if (im[m] < measurements_[m].size() && measurements_[m][im[m]].utime < next) {
        next = measurements_[m][im[m]].utime;
        kind = 1 + static_cast<int>(m);
      }
    }
    if (kind < 0) break;
    if (kind == kOdometryKind) {
      const OdometryStep& step = odometry_[io].value;
      if (state.utime < step.t_end && step.t_start < step.t_end) {
        // The step's motion, then what it did not see (contact, push) up to its end, then its
        // velocity measured at the end.
        const Utime before = state.utime;
        predictOdometryPart(state, step, step.t_end, params_.noise);
        addUnseen(state, before, state.utime);
        updateOdometryVelocity(state, step, params_.noise);
      }
      ++io;
    } else {
      const std::size_t m = static_cast<std::size_t>(kind - 1);
      const PoseMeasurement& z = measurements_[m][im[m]].value;
      // A refused measurement leaves no trace, not even the split of the odometry interval.
      EkfState updated = state;
      carryTo(updated, z.utime);
      const UpdateResult u = updatePose(updated, z, params_.gate2, params_.slip);
      if (u.accepted) state = updated;
      if (kind == target_kind && z.utime == t) {
        applied.found = true;
        applied.update = u;
      }
      ++im[m];
    }
    // One checkpoint per instant: inputs at the same time share it (an input that left the
    // state where it was rewrites an identical state).
    if (checkpoints_.back().utime == state.utime) {
      checkpoints_.back() = state;
    } else {
      checkpoints_.push_back(state);
    }
  }
  return applied;
}

void DelayedFilter::prune() {
  const Utime limit = newest_input_ - params_.window_us;
  if (initialized()) {
    while (checkpoints_.size() > 1 && checkpoints_[1].utime <= limit)
      checkpoints_.pop_front();
    const Utime base = checkpoints_.front().utime;
    odometry_.dropBefore(base + 1);
    for (auto& channel : measurements_)
      channel.dropBefore(base + 1);
    // Evidence still covering the base stays: it widens the intervals after it.
    while (!contacts_.empty() && contacts_.front() + params_.contact.hold_us < base)
      contacts_.pop_front();
  } else {
    odometry_.dropBefore(limit);
    for (auto& channel : measurements_)
      channel.dropBefore(limit);
    while (!contacts_.empty() && contacts_.front() + params_.contact.hold_us < limit)
      contacts_.pop_front();
  }
}

std::optional<EkfState> DelayedFilter::stateAt(Utime t) const {
  if (!initialized() || t < checkpoints_.front().utime) return {};
  auto it = std::upper_bound(checkpoints_.begin(), checkpoints_.end(), t,
                             [](Utime v, const EkfState& s) { return v < s.utime; });
  EkfState s = *std::prev(it);
  carryTo(s, t);
  return s;
}

}  // namespace fieldline::fusion
