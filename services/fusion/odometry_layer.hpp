// Layer 1 of the localization (seed 4.8): accumulated wheel ticks -> wheel rotations (eq. 4.62,
// 4.63) -> the body's movement through the inverse wheel matrix (M^-1, the robot-frame form of
// W(phi)^-1, eq. 4.35; for four wheels the least-squares inverse (M^T M)^-1 M^T), with a
// covariance that grows with the distance driven and the angle turned: each wheel's ground travel
// is uncertain by its own slip and tick quantisation, carried through the same inverse. A
// controller without ticks (odometry_t wheel_count 0) gives its own movement instead; the same
// per-wheel model then applies to the wheel travel that movement implies. Samples must come in time
// order; a sample that cannot be trusted (time running backwards, a jump no wheel can make, a
// controller resync) is refused with its reason and restarts the reference, so a bad sample never
// becomes a movement. A sample's utime is the bridge's stamp: the controller's own clock mapped
// onto the host's (common/time/ controller_clock.hpp), without the serial link's jitter.
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "common/geometry/geometry.hpp"
#include "common/robot/omni_kinematics.hpp"
#include "common/robot/robot_params.hpp"
#include "common/robot/wheel_odometry.hpp"
#include "common/time/clock.hpp"

namespace fieldline::fusion {

struct OdometryNoise {
  // Standard deviation of a wheel's rotation relative to the rotation (slip), 1.
  double wheel_relative_sigma = 0.03;
  // Wheel slip as white noise on each wheel's contact speed, relative to that speed, 1/sqrt(s):
  // a wheel that rolls d metres in dt seconds is off by density * d / sqrt(dt) (one sigma). The
  // error of a short step is large relative to its length, and averages out over longer ones.
  double wheel_slip_density = 0.017;
  // Random rotation rate while driving, rad/s per m/s of speed, as white noise (1/sqrt(s)).
  double rotation_slip_density = 0.01;
  // Extra translation noise per metre driven, m/m (floor, carpet seams).
  double translation_sigma_per_m = 0.025;
  // Extra heading noise per radian turned and per metre driven, rad/rad and rad/m.
  double rotation_sigma_per_rad = 0.02;
  double rotation_sigma_per_m = 0.01;
  // A sample interval longer than this is a gap: the movement is still used (the ticks
  // accumulate), but no velocity is derived from it, s.
  double max_interval_s = 0.25;
  // Wheel speeds above this multiple of the robot's top wheel speed are an odometry jump.
  double max_speed_factor = 3.0;
  // With the controller's gyro (odometry_t STATUS_GYRO) the heading increment of a step is the
  // gyro's, with the noise of its error model (the robot file's `gyro:` section); the wheels still
  // give the translation. False: the wheels' heading, as without a gyro.
  bool use_gyro = true;
  // A gyro increment faster than this is absurd (counted, the step falls back to the wheels'
  // heading), rad/s; 0: 1.05 times the gyro's range.
  double gyro_max_rate = 0.0;
  // Extra white noise on the gyro's heading increments beyond its data sheet (stamp jitter,
  // the simulator's twist between rate samples), rad/sqrt(s).
  double gyro_heading_density = 0.03;
};

// One odometry sample as the controller sends it (the few fields of odometry_t fusion needs).
struct OdometrySample {
  Utime utime = 0;
  // One count per wheel of the robot file, or none from a controller that reports only its
  // movement (then `movement` is it).
  robot::TickCounts ticks;
  // The controller says the counters restarted (odometry_t::STATUS_RESYNC).
  bool resync = false;
  // The controller's own time of the sample, µs since it started (0: not known).
  std::int64_t controller_utime = 0;
  // The controller's mean wheel currents over the sample period [A] (odometry_t
  // STATUS_CURRENTS), one per wheel, for contact detection (current_contact.hpp); unchecked here.
  bool has_currents = false;
  robot::PerWheel<double> wheel_current;
  // The gyro's rotation since the controller's previous sample [rad] (odometry_t STATUS_GYRO),
  // raw: bias and scale error still in it. Checked here.
  bool has_gyro = false;
  double gyro_dphi = 0.0;
  // The controller's own movement since its previous sample (odometry_t dx, dy, dphi); used only
  // without ticks.
  geometry::Movement movement;
};

// The movement between two samples, ready for the filter.
struct OdometryStep {
  Utime t_start = 0;
  Utime t_end = 0;
  // Body twist integrated over the interval (dx, dy along the body axes at the start, dphi):
  // the movement is the arc geometry::arcMovement of it (robot::arcMovement).
  Eigen::Vector3d integrated = Eigen::Vector3d::Zero();
  // Covariance of `integrated`, m^2 / m*rad / rad^2.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  // False after a gap: the interval is too long to read a velocity from.
  bool has_velocity = true;
  // integrated.z() is the gyro's raw rotation (the filter subtracts its bias estimate), and
  // the covariance's heading row and column are the gyro's error model.
  bool gyro = false;

  double duration() const { return static_cast<double>(t_end - t_start) * 1e-6; }
};

enum class OdometryRejection {
  kNone,
  kOutOfOrder,
  kDuplicate,
  kJump,
  kResync,
  kGap,
  // Ticks for another number of wheels than the robot file's: refused (and the reference
  // restarts), they mean nothing with this geometry.
  kWheelCount,
  // Without ticks, a movement that is not finite.
  kNotFinite,
};
const char* toString(OdometryRejection r);

class OdometryLayer {
 public:
  explicit OdometryLayer(const robot::RobotParams& params, OdometryNoise noise = {});

  struct Result {
    // Set when a movement since the previous sample is available.
    std::optional<OdometryStep> step;
    // Why the sample gave no step (kNone for the very first sample: it only sets the reference).
    OdometryRejection rejection = OdometryRejection::kNone;
    // Set when the sample's gyro value was refused ("gyro_not_finite", "gyro_absurd"): the
    // step then takes the wheels' heading.
    const char* gyro_rejection = nullptr;
  };
  Result update(const OdometrySample& sample);
  // The utime of the most recent sample update() saw (0 before the first): the physical time of
  // its sampling, as the bridge stamped it.
  Utime lastStamp() const { return last_stamp_; }

  // The step and its covariance for a tick difference over `dt_s` seconds (tests, tools; the
  // slip densities need the interval, dt_s <= 0 leaves them out).
  OdometryStep stepFor(const robot::TickDeltas& tick_delta, double dt_s = 0.0) const;
  // The same for each wheel's ground travel [m] (one per wheel).
  OdometryStep stepForTravel(const robot::WheelVector& ground, double dt_s = 0.0) const;

  // Forgets the reference; the next sample starts over.
  void reset() { last_.reset(); }
  // The gyro's variance of a heading increment `dphi` over `dt_s` seconds (white noise, scale
  // error; its bias is the filter's), rad^2.
  double gyroVariance(double dphi, double dt_s) const;
  const robot::OmniKinematics& kinematics() const { return odometry_.kinematics(); }

 private:
  // Makes `sample` the reference, dropping what was pending.
  void restartAt(const OdometrySample& sample);
  // Why the sample gives no step (bad, a resync, the first, a duplicate), with the reference
  // restarted or forgotten as each calls for (kNone: the first sample, now the reference); none
  // when it gives a step from the reference (or is out of order).
  std::optional<OdometryRejection> noStepReason(const OdometrySample& sample);
  // True if the sample's gyro value is to be used; `rejection` says why one was refused.
  bool gyroUsable(const OdometrySample& sample, const char*& rejection) const;
  // A sample stamped before the reference: its gyro rotation and movement kept for the next
  // step (or, far back, the reference restarts from it).
  void holdOutOfOrder(const OdometrySample& sample, bool gyro_ok);
  // Each wheel's ground travel since the reference; without ticks, `integrated` gets the
  // controller's movement (pending and this sample's) as an integrated twist.
  robot::WheelVector groundTravel(const OdometrySample& sample, Eigen::Vector3d& integrated) const;

  robot::RobotParams params_;
  OdometryNoise noise_;
  robot::WheelOdometry odometry_;
  std::optional<OdometrySample> last_;
  // Gyro rotation of samples after the reference that gave no step of their own (stamps out of
  // order), and whether every sample since the reference carried a valid one.
  double pending_gyro_ = 0.0;
  // Without ticks: the movements of such samples, composed.
  geometry::Movement pending_movement_;
  bool pending_gyro_valid_ = true;
  double gyro_max_rate_ = 0.0;
  Utime last_stamp_ = 0;
};

}  // namespace fieldline::fusion
