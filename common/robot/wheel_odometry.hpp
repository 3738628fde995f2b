// Layer 1 of the seed (4.8): accumulated wheel ticks -> wheel rotations -> robot movement.
//
// The controller sends the accumulated tick count of every wheel at 50 Hz. The difference of
// two samples (eq. 4.62) times 2 pi / n_ticks is the wheel rotation (eq. 4.63); the nominal
// kinematics turn the wheels' rotations into the body's movement over the interval, taken as an
// arc of constant twist (eq. 4.65 with the twist held over the 20 ms sample).
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "common/geometry/geometry.hpp"
#include "common/robot/omni_kinematics.hpp"
#include "common/robot/robot_params.hpp"

namespace fieldline::robot {

// Accumulated encoder ticks, one per wheel (3 or 4), wrapping as int32.
using TickCounts = PerWheel<std::int32_t>;
// Differences of two tick samples, one per wheel.
using TickDeltas = PerWheel<std::int64_t>;

// Difference of two accumulated counters that may have wrapped around 2^32.
std::int32_t tickDelta(std::int32_t newer, std::int32_t older);

class WheelOdometry {
 public:
  // Uses the nominal geometry and ticks per revolution of `params`.
  explicit WheelOdometry(const RobotParams& params);

  // Wheel rotations [rad] for a tick difference (eq. 4.63).
  WheelVector wheelRotations(const TickDeltas& tick_delta) const;
  // The movement, in the robot frame at the start, for a tick difference.
  geometry::Movement movement(const TickDeltas& tick_delta) const;

  // Feeds the next accumulated sample (one count per wheel of the robot). The first sample only
  // sets the reference (nullopt); later ones return the movement since the previous one and
  // advance pose(). Throws std::invalid_argument for another number of wheels.
  std::optional<geometry::Movement> update(const TickCounts& accumulated);

  // Dead-reckoned pose in the odometry frame (starts at the pose given to reset()).
  const geometry::Pose2& pose() const { return pose_; }
  // Forgets the reference sample and restarts integration at `start`.
  void reset(const geometry::Pose2& start = {});

  const OmniKinematics& kinematics() const { return kinematics_; }
  int ticksPerRevolution() const { return ticks_per_revolution_; }

 private:
  OmniKinematics kinematics_;
  int ticks_per_revolution_;
  std::optional<TickCounts> last_;
  geometry::Pose2 pose_;
};

}  // namespace fieldline::robot
