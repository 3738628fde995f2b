// The extended Kalman filter of seed 4.5-4.6 on the state (x, y, phi, vx, vy, omega, b, ux, uy):
// position and heading in the field frame, velocity in the field frame, the bias b of the
// controller's yaw-rate gyro, and a push velocity (ux, uy) in the field frame: what an opponent
// carrying the robot adds to the position while the wheels slip and see nothing (PushModel). Plain
// functions on a state so the delayed-measurement history (history.hpp) can checkpoint and replay
// them.
//
// Process: between samples the velocity is held (the filter does not see the commands) and the
// motor model (eq. 4.45-4.47) bounds how fast it can change: its largest acceleration, projected
// through W(phi)^-1, sets the velocity's process noise. Odometry moves the pose by layer 1's
// movement (a control input with its own covariance) and measures the velocity. A step whose
// heading comes from the gyro (OdometryStep::gyro) turns the heading by the gyro's rotation
// minus b times its duration; b is a random walk, learnt from the line frames' headings (without
// gyro steps it is coupled to nothing and changes nothing). The push velocity moves the position
// on top of odometry; it is a random walk while the robot is in contact and decays to zero
// outside it (predictPush), learnt from the frames' position corrections. Pose
// measurements (layers 2 and 3) update with the Joseph form, the heading innovation wrapped,
// behind a Mahalanobis gate.
#pragma once

#include <limits>

#include <Eigen/Core>

#include "common/geometry/geometry.hpp"
#include "common/robot/motor_model.hpp"
#include "common/robot/omni_kinematics.hpp"
#include "common/time/clock.hpp"
#include "services/fusion/odometry_layer.hpp"

namespace fieldline::fusion {

inline constexpr int kStateSize = 9;
// Index of the gyro bias in the state.
inline constexpr int kGyroBias = 6;
// Index of the push velocity's x component (y follows) in the state.
inline constexpr int kPush = 7;
using StateVector = Eigen::Matrix<double, kStateSize, 1>;
using StateMatrix = Eigen::Matrix<double, kStateSize, kStateSize>;

struct EkfState {
  Utime utime = 0;
  // x, y [m], phi [rad] in (-pi, pi], vx, vy [m/s] field frame, omega [rad/s], gyro bias [rad/s],
  // push velocity ux, uy [m/s] field frame.
  StateVector x = StateVector::Zero();
  StateMatrix p = StateMatrix::Identity();
  // The last odometry step turned the heading by the gyro (the contact noise's heading density
  // depends on it).
  bool gyro = false;
  // Time of the last accepted pose measurement (0: none yet) and the size of its correction.
  Utime last_correction_utime = 0;
  double last_correction_m = 0.0;
  double last_correction_rad = 0.0;

  geometry::Pose2 pose() const { return {x[0], x[1], x[2]}; }
  // How the robot moves over the ground, field frame (vx + ux, vy + uy, omega): the wheels'
  // velocity plus the push an opponent gives it.
  Eigen::Vector3d groundVelocity() const { return {x[3] + x[kPush], x[4] + x[kPush + 1], x[5]}; }
};

struct ProcessNoise {
  // Standard deviation of the linear and angular acceleration the filter does not see, m/s^2
  // and rad/s^2 (white noise density per sqrt(s)).
  double linear_acceleration = 2.0;
  double angular_acceleration = 6.0;
  // Extra position noise while no odometry covers an interval, m/sqrt(s).
  double position_density = 0.05;
  double heading_density = 0.05;
  // Velocity measured from odometry: extra standard deviation, m/s and rad/s.
  double odometry_velocity_sigma = 0.05;
  double odometry_omega_sigma = 0.1;
  // The gyro bias's random walk, rad/s per sqrt(s) (robot file `gyro.bias_walk`).
  double gyro_bias_walk = 0.0;

  // Acceleration noise from the motor model: a wheel accelerates at most alpha / m (full
  // command from standstill, eq. 4.45-4.46); W(phi)^-1 (eq. 4.47) turns that into the body.
  static ProcessNoise fromMotorModel(const robot::MotorModel& motor,
                                     const robot::OmniKinematics& kinematics);
};

// A pose measurement of layer 2 or 3 at its own time.
struct PoseMeasurement {
  Utime utime = 0;
  geometry::Pose2 pose;
  // Covariance of (x, y, phi).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  // A trusted measurement (a frame that matches the field well): when it disagrees with the
  // state beyond the gate but within SlipModel's limits, the robot slipped or was pushed (a
  // collision odometry cannot see), and the state's pose covariance is widened before the update.
  bool may_reveal_slip = false;
  // Its heading may be weighted down when it alone disagrees with a gyro heading
  // (SlipModel::gyro_heading_chi2); false for a heading that two frames agree on.
  bool robust_heading = false;
};

// What a trusted measurement that contradicts the state is taken to mean: the pose moved in a way
// odometry did not see (wheels spinning against an obstacle, a push, a twist). Within these
// limits the pose covariance grows by `inflation` times the innovation's square per axis and the
// measurement is applied; beyond them it is refused by the gate as usual.
struct SlipModel {
  double max_m = 0.5;
  double max_rad = 0.5;
  // ... instead of max_rad while the heading comes from the gyro (EkfState::gyro): it sees a
  // twist, so a frame whose heading disagrees beyond this is a wrong match, not a slip.
  double max_rad_gyro = 0.5;
  // A slip is a movement, and a movement takes time: since the state's last accepted correction
  // the pose cannot have slipped farther than base_m + max_speed * elapsed (a push by an
  // opponent at 3 m/s, wheels spinning against an obstacle). A frame whose disagreement is
  // beyond that, 33 ms after the last correction, is a wrong match (an aliased line 1 m away),
  // not a slip. max_speed 0: no time bound (max_m alone), m/s, m.
  double max_speed = 0.0;
  double base_m = 0.0;
  // The time bound: how far the pose of `s` may have slipped by `utime` since its last accepted
  // correction, m (infinite without max_speed or before any correction).
  double reachBy(const EkfState& s, Utime utime) const {
    if (!(max_speed > 0.0) || s.last_correction_utime <= 0) return kNoBound;
    const Utime elapsed = utime > s.last_correction_utime ? utime - s.last_correction_utime : 0;
    return base_m + max_speed * static_cast<double>(elapsed) * 1e-6;
  }
  static constexpr double kNoBound = std::numeric_limits<double>::infinity();
  // 0: no slip handling.
  double inflation = 2.0;
  // While the heading comes from the gyro (EkfState::gyro), a measurement with robust_heading
  // whose heading alone disagrees beyond this (squared, with the state's and its own heading
  // variance, 1 dof) has its heading variance raised until it sits on this bound (a Huber weight):
  // a single frame's heading error of several degrees (2 % of the frames of a recorded match,
  // uncorrelated from frame to frame) no longer turns the gyro's heading, and its position still
  // counts, also as a slip (which then widens the position only). 0: off.
  double gyro_heading_chi2 = 0.0;
};

// Contact with another robot, as the robot's own camera tells it (an obstacle's near edge close to
// the body in VISION_OBSTACLES): while in contact the simulator (and a real carpet) twists and
// pushes the robot in ways the wheels do not see, so the pose's process noise grows by these
// densities for `hold_us` after each frame that showed contact. `distance_m` 0: off.
struct ContactModel {
  // A frame whose nearest obstacle is closer than this (robot centre to the obstacle's nearest
  // floor point) is contact evidence, m.
  double distance_m = 0.0;
  // How long one such frame keeps the robot in contact, µs (the touching obstacle disappears
  // into the mirror's blind centre once it touches).
  Utime hold_us = 400'000;
  // Extra position and heading noise while in contact, m/sqrt(s) and rad/sqrt(s).
  double position_density = 0.0;
  double heading_density = 0.0;
  // The heading's extra noise in contact when the heading comes from the gyro, which sees the
  // twist the wheels miss (what is left: saturation, the stamps), rad/sqrt(s).
  double gyro_heading_density = 0.0;
};

// A push (docs/fusion.md, "Contact"): an opponent carries a touching robot at up to 3 m/s,
// the wheels slip and odometry sees nothing, and every frame finds the estimate 10-15 cm off. The
// push velocity (ux, uy) adds to the position between frames; it is an Ornstein-Uhlenbeck process
// per axis: while in contact (ContactModel's evidence) a random walk of `density` decaying with
// `contact_decay_s`, outside contact it decays with `free_decay_s` and gets no noise. Its
// coupling to the position lets a frame's position correction teach it the push, so the states
// after the frame carry the push on. density 0: off (the push stays at zero and changes nothing).
struct PushModel {
  // Random walk of the push velocity while in contact, m/s per sqrt(s).
  double density = 0.0;
  // Decay time constants in and out of contact, s (> 0).
  double contact_decay_s = 0.5;
  double free_decay_s = 0.1;
  // The push's speed is held within this after each prediction (opponents drive at most 3 m/s;
  // a push learnt from a wrong frame must not run away), m/s. 0: no bound.
  double max_speed = 0.0;
  // Only frames tell the push: once the state's last accepted correction is older than this, the
  // push decays as outside contact (a robot whose frames are refused or searched, twisted in a
  // collision, ran off at the push's speed for metres), µs. 0: no limit.
  Utime unconfirmed_us = 0;
};

struct UpdateResult {
  bool accepted = false;
  // Squared Mahalanobis distance of the innovation.
  double mahalanobis2 = 0.0;
  // Size of the correction applied: position m, heading rad.
  double correction_m = 0.0;
  double correction_rad = 0.0;
  // The gate was passed only after widening the covariance for a slip (SlipModel).
  bool slip = false;
  // The measurement's heading was weighted down against the gyro's (SlipModel::gyro_heading_chi2).
  bool heading_weighted_down = false;
  // The measurement's heading disagreement, rad (measurement minus state).
  double heading_innovation = 0.0;
};

// Moves the state to `t` with the velocity held, for time no odometry covers (adds
// ProcessNoise::position_density and heading_density).
void predictConstantVelocity(EkfState& s, Utime t, const ProcessNoise& noise);
// Moves the state to `t` inside the odometry step's interval with the part of the step between
// s.utime and t: that fraction of its movement and of its covariance (the state is first carried
// to t_start with the velocity if it is older; t beyond t_end is taken as t_end). No velocity
// measurement: that comes with the step's end (predictOdometry).
void predictOdometryPart(EkfState& s, const OdometryStep& step, Utime t, const ProcessNoise& noise);
// Moves the state to step.t_end with the part of the odometry step after s.utime (the whole
// step when the state is at its start; the state is first carried to t_start if it is older),
// then measures the velocity with it: predictOdometryPart to t_end and updateOdometryVelocity.
void predictOdometry(EkfState& s, const OdometryStep& step, const ProcessNoise& noise);
// The step's mean velocity as a measurement of (vx, vy, omega) (plus the gyro bias when its
// heading comes from the gyro), for a state at step.t_end; nothing otherwise.
void updateOdometryVelocity(EkfState& s, const OdometryStep& step, const ProcessNoise& noise);
// Moves the push velocity over the `dt_s` seconds that end at s.utime (of which `contact_s` were
// in contact) and adds its effect to the position: the exact discretisation of PushModel's
// process with the decay rate and noise averaged over the interval (a constant rate composes: two
// parts equal the whole). Nothing happens when the push is off.
void predictPush(EkfState& s, double dt_s, double contact_s, const PushModel& push);
// Updates with a pose measurement at s.utime. With gate2 > 0, a measurement whose squared
// Mahalanobis distance exceeds it is not applied.
UpdateResult updatePose(EkfState& s, const PoseMeasurement& z, double gate2,
                        const SlipModel& slip = {});
// True if `c` is symmetric (to rounding) and positive definite.
bool isPositiveDefinite(const Eigen::Matrix3d& c);

// The pose the field's point symmetry through the centre spot maps `p` to: (-x, -y, phi + pi).
geometry::Pose2 symmetricTwin(const geometry::Pose2& p);
// The same symmetry applied to
// a state (field-frame velocities and push negated, turn rate and gyro bias kept, the covariance
// transformed alike) and to a pose measurement: a history mapped this way is exactly the one the
// filter would have had with the twin's measurements.
EkfState pointMirrored(const EkfState& s);
PoseMeasurement pointMirrored(const PoseMeasurement& z);

}  // namespace fieldline::fusion
