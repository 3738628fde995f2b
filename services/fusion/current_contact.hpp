// Contact from the motor currents (ODOMETRY's wheel_current): a robot pushed or twisted by
// another one makes its wheels slip, and the controller's current rises to the friction limit,
// beyond what the wheel's own acceleration needs. Per odometry sample the detector predicts each
// wheel's current from its acceleration (mean wheel speeds from the ticks of the neighbouring
// samples, the wheel's share of the robot's mass (a third, a quarter with four wheels), wheel
// radius, gear, torque constant) and flags contact when the rest, as a force at the wheel, exceeds
// a threshold on some wheel in `samples` consecutive samples. The periods are measured on the
// controller's clock when the samples carry it (the host's receive times jitter with its load; the
// currents are averaged over the controller's periods). Plain logic: no clock, no LCM.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "common/robot/robot_params.hpp"
#include "common/time/clock.hpp"
#include "services/fusion/odometry_layer.hpp"

namespace fieldline::fusion {

struct CurrentContactParams {
  // Force at a wheel beyond what its acceleration explains that counts as slipping [N]; 0: off.
  double force_threshold_n = 10.0;
  // Consecutive samples beyond the threshold before a contact is reported (the carpet's random
  // slip rarely lasts two samples, a push does).
  int samples = 2;
  // Currents beyond this are not a motor's: refused and counted ("current_absurd") [A].
  double max_current_a = 40.0;
  // Samples further apart than this break the history (no acceleration across a gap) [s].
  double max_interval_s = 0.1;
};

class CurrentContactDetector {
 public:
  CurrentContactDetector(const robot::RobotParams& robot, CurrentContactParams params);

  struct Result {
    // Contact: the start of the sample period whose currents showed it (µs, the odometry's
    // clock).
    std::optional<Utime> contact;
    // A refused sample's reason ("current_not_finite", "current_absurd"), else empty.
    std::string rejection;
  };
  // One odometry sample in time order. Samples without currents, with a resync, or after a gap
  // restart the history; refused currents also restart it (the ticks are the odometry layer's).
  Result add(const OdometrySample& sample);

  // The largest residual force of the last judged sample [N] (for tests and traces).
  double lastResidualN() const { return last_residual_n_; }
  bool enabled() const { return params_.force_threshold_n > 0.0; }

 private:
  struct Entry {
    Utime utime = 0;
    std::int64_t controller_utime = 0;
    robot::TickCounts ticks;
    robot::PerWheel<double> current;
  };

  CurrentContactParams params_;
  // Per wheel: ground travel per tick [m], newtons per ampere; the wheel's share of the mass [kg].
  robot::PerWheel<double> metres_per_tick_;
  double share_kg_ = 0.0;
  robot::PerWheel<double> newtons_per_amp_;
  std::deque<Entry> history_;
  int beyond_ = 0;
  double last_residual_n_ = 0.0;
};

}  // namespace fieldline::fusion
