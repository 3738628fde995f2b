// The delay-aware filter (seed 4.7): every input is kept in a time-indexed channel by the time it
// was observed, and the filter's state is checkpointed after each instant it processed. A
// measurement older than the newest state rewinds to the checkpoint before it and replays
// everything after it, so the answer is exactly what in-order processing would have given.
//
// Inputs are refused, counted by reason and change nothing when they come from the future, are
// older than the window, carry NaN, or a covariance that is not positive definite.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>

#include "common/time/timed_channel.hpp"
#include "services/fusion/ekf.hpp"
#include "services/fusion/odometry_layer.hpp"

namespace fieldline::fusion {

// Layer 2 (line matching) and layer 3 (feature hypotheses) measurements live in separate
// channels: both come from the same frame, with the same utime.
enum class MeasurementSource : std::uint8_t { kLines = 0, kFeatures = 1 };

enum class Rejection : std::uint8_t {
  kNone = 0,
  kFromFuture,
  kTooOld,
  kNotFinite,
  kNotPositiveDefinite,
  kDuplicate,
  kGated,
  kNotInitialized,
  kCount
};
const char* toString(Rejection r);

struct FilterParams {
  // How far back a late input may reach, µs.
  Utime window_us = 1'000'000;
  // Inputs later than now + this are from the future, µs.
  Utime future_tolerance_us = 50'000;
  // Squared Mahalanobis distance beyond which a pose measurement is refused (3 dof; 0: no gate).
  double gate2 = 16.27;
  ProcessNoise noise;
  // Trusted measurements beyond the gate: a slip odometry did not see (collisions).
  SlipModel slip;
  // Contact evidence widens the pose's process noise (ContactModel).
  ContactModel contact;
  // The push velocity's process: a random walk while contact evidence covers the time (PushModel).
  PushModel push;
};

class DelayedFilter {
 public:
  explicit DelayedFilter(FilterParams params = {});

  // (Re)starts the filter at `state` (its utime included) and replays the stored inputs after
  // it. Inputs at or before state.utime are dropped.
  void initialize(const EkfState& state);
  bool initialized() const { return !checkpoints_.empty(); }
  // Maps the whole history through the field's point symmetry (pointMirrored): every checkpoint
  // and stored pose measurement; odometry (robot frame) and contact evidence stay. Late inputs
  // then replay onto the twin's history exactly as onto the original one.
  void mirrorThroughCentre();
  // Forgets the estimate (inputs stay; a later initialize() replays them).
  void forget() { checkpoints_.clear(); }

  // Stores an odometry step (by its end time) and processes it. Steps are stored before the
  // filter is initialized, so initialize() can replay them.
  Rejection addOdometry(const OdometryStep& step, Utime now);

  struct PoseResult {
    Rejection rejection = Rejection::kNone;
    UpdateResult update;
  };
  PoseResult addPose(MeasurementSource source, const PoseMeasurement& z, Utime now);

  // Stores a frame's contact evidence (its exposure time) and replays what came after it: from
  // `utime` for params().contact.hold_us the pose's process noise grows (ContactModel). Like any
  // input it is refused when from the future or older than the window; a second one at the same
  // time is a duplicate (refused, changes nothing).
  Rejection addContact(Utime utime, Utime now);
  // True when contact evidence covers `t` (a frame at or before it within the hold).
  bool inContact(Utime t) const;

  // The state after the newest input. Requires initialized().
  const EkfState& current() const { return checkpoints_.back(); }
  // The state at `t` (from the checkpoint at or before it, carried on as carryTo does); empty
  // before the history or when not initialized.
  std::optional<EkfState> stateAt(Utime t) const;
  // The newest input time (odometry or measurement), 0 when none.
  Utime newestInput() const { return newest_input_; }

  const std::array<std::uint64_t, static_cast<std::size_t>(Rejection::kCount)>& rejections() const {
    return rejections_;
  }
  std::uint64_t replays() const { return replays_; }
  const FilterParams& params() const { return params_; }

 private:
  struct Applied {
    bool found = false;
    UpdateResult update;
  };
  Rejection checkTime(Utime utime, Utime now) const;
  // Time in [a, b] covered by contact evidence, s.
  double contactSeconds(Utime a, Utime b) const;
  // What the odometry does not see over the interval [a, b] that ends at s.utime: the contact
  // noise on the pose covariance and the push velocity's process (predictPush).
  void addUnseen(EkfState& s, Utime a, Utime b) const;
  // Carries the state (the newest processed at or before t) to `t`: inside a stored odometry
  // step's interval with that step's part up to t (its motion and covariance in proportion),
  // with the velocity only where no stored step covers t; plus the contact noise.
  void carryTo(EkfState& s, Utime t) const;
  // Rewinds to the last checkpoint before `t` and replays every input after it. Returns the
  // update result of the pose measurement `target_source` at `t`, when it was replayed.
  Applied replayFrom(Utime t, int target_kind);
  void prune();
  Rejection count(Rejection r) {
    ++rejections_[static_cast<std::size_t>(r)];
    return r;
  }

  FilterParams params_;
  TimedChannel<OdometryStep> odometry_;
  std::array<TimedChannel<PoseMeasurement>, 2> measurements_;
  // Times of the frames that showed contact, ascending.
  std::deque<Utime> contacts_;
  // checkpoints_[0]: the base (everything at or before its utime is in it); then the state after
  // each processed instant, in time order.
  std::deque<EkfState> checkpoints_;
  Utime newest_input_ = 0;
  std::array<std::uint64_t, static_cast<std::size_t>(Rejection::kCount)> rejections_{};
  std::uint64_t replays_ = 0;
};

}  // namespace fieldline::fusion
