// The ball (seed 4.14's second estimate): each sighting, in the robot frame at the frame's
// exposure time, is moved into the field frame with the robot's pose at that same time, and a
// constant-velocity Kalman filter with rolling friction tracks it. Unseen for long enough, the
// estimate says so (valid = false) instead of extrapolating forever.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "common/perception/estimates.hpp"
#include "common/time/clock.hpp"
#include "services/fusion/ekf.hpp"

namespace fieldline::fusion {

struct BallFilterParams {
  // Deceleration of a rolling ball, m/s^2.
  double rolling_deceleration = 0.4;
  // Unseen acceleration of a rolling ball, white-noise density, m/s^1.5.
  double acceleration_density = 0.3;
  // Two models: a ball at rest (estimated slower than rest_speed_mps, its newest sighting within
  // rest_max_nis, the squared Mahalanobis distance of the innovation) only moves when something
  // hits it, which the outlier restart catches; meanwhile it is still, and its unseen
  // acceleration is rest_acceleration_density, so its sightings average. One rolling, or a
  // sighting beyond rest_max_nis (it started to roll), takes acceleration_density. A ball that
  // starts to roll from rest is an outlier row and restarts with the row's velocity.
  // Synthetic resting ball seen for 2 s at 30 Hz, 90 ms after the last sighting: error 14 mm
  // with one model, 5 mm with these (rest_max_nis at 95 % instead of 99 % restarted the averaging
  // one sighting in twenty: 6 mm). m/s^1.5, m/s, 1.
  double rest_acceleration_density = 0.02;
  double rest_speed_mps = 0.15;
  double rest_max_nis = 9.21;
  // BALL_STATE of a ball at rest: its position covariance is the filter's at the last sighting
  // plus the resting model's growth, not grown by the velocity's uncertainty over the time since
  // (about 90 ms): resting balls' sigmas were 1.3-3 times their errors in hidden_ball and the team
  // ball too wide (team NEES below the band 17 %; replayed 0.818 -> 0.844 in band).
  bool rest_holds_place = true;
  // The reported covariance (not the filter's) grows by this squared times the velocity's outer
  // product: a rolling ball's place at a stamp is uncertain by its speed times the stamps'
  // uncertainty (exposure, the pose's time, the bus). 10 ms: the same frames' stamps are 8 ms
  // uncertain for the line corrections (localizer correction_stamp_sigma_s), a camera stamped
  // on receipt jitters by the host's load, and the match's rolling balls seen from under 3 m are
  // off by 3-8 ms times their speed (median; docs/teamcomm.md "Team ball"). 0: off, s.
  double stamp_sigma_s = 0.01;
  // The estimate is invalid after this long without a sighting, s.
  double max_age_s = 0.5;
  // A sighting after the estimate expired (unseen for longer than max_age_s) starts the filter
  // again at it (at rest, as the first one does) instead of updating the expired state, whose
  // covariance, grown over the gap, takes nearly any sighting through the gate and gives the
  // distance to its stale prediction to the velocity: far robots re-acquiring a resting ball
  // reported it rolling at 0.3-2 m/s and 10-30 cm off for up to half a second. The restarted
  // estimate is valid once a next sighting agrees. Off by default: in replays of ten live
  // matches the team ball gained 3-11 mm in nine, but in one a robot whose heading was 0.2-0.8
  // rad off (a collision) re-acquired the ball 1.3-3.2 m off, which the expired filter had refused
  // as outliers; docs/log/2026-12-08-session15-teamball.md.
  bool restart_when_expired = false;
  // Squared Mahalanobis distance (2 dof) beyond which a sighting is an outlier.
  double gate2 = 13.8;
  // After this many outliers in a row the ball has moved for real (kicked, put back): restart.
  int restart_after_outliers = 3;
  // Sightings further than this from the robot are too coarse to use, m.
  double max_range_m = 9.0;
  // Added (in quadrature) to a sighting's radial and tangential sigmas: what the camera's own
  // figures leave out (its exposure against the robot's turning, the ball's blur), m.
  double sighting_floor_m = 0.0;
  // An outlier makes the estimate invalid until a sighting agrees again or the filter restarts
  // (the ball was kicked or bounced: where the filter thinks it is, it is not).
  bool invalid_after_outlier = true;
  // A confident sighting (radial and tangential sigmas at most `restart_max_sigma_m`) further
  // than this from the prediction restarts the filter at it at once: the ball was put somewhere
  // else or bounced off a robot, and the sighting is better than the old estimate. 0: off, m.
  double restart_distance_m = 0.0;
  double restart_max_sigma_m = 0.15;
  // The robot's pose at a sighting's time counts as confirmed when an accepted line correction
  // was at most this long before. While the frames are gated (a robot twisted in a collision),
  // the heading can be off by a radian and a sighting lands metres away, where three in a row
  // restarted the ball. A sighting with an unconfirmed pose is fused only when it agrees with the
  // prediction; otherwise (it only makes the estimate invalid, invalid_after_outlier), and for
  // starting the filter or a frame without the ball (unseen_range_m), it is refused
  // (kPoseUnconfirmed). 0: off, s.
  double pose_max_unconfirmed_s = 0.15;
  // BallTracker: the pose is confirmed only when the next accepted correction after the sighting
  // (within pose_max_unconfirmed_s) moved the heading by at most this, rad.
  double pose_max_correction_rad = 0.1;
  // When the filter restarts after outliers, a straight path fitted through the row of outliers
  // (those at most `pair_max_age_s` older) and the restarting sighting gives the velocity, if
  // the sightings lie on it and it is at most `pair_max_speed` m/s: the ball rolls on as they say
  // instead of starting from rest (a kick, a bounce). false: restart at rest.
  bool velocity_from_pair = true;
  // Velocity standard deviation of a filter (re)started at rest: a ball just kicked or bounced
  // may roll at several m/s, and the next sighting must not be an outlier for that, m/s.
  double restart_speed_sigma = 2.0;
  double pair_max_age_s = 0.25;
  // Sightings (the row's and the restarting one) the path needs; from 3 on, they must lie on
  // it (two sightings always make a path, a false one included).
  int fit_min_sightings = 3;
  // Also the fastest ball an update may make: a sighting that would make it faster restarts the
  // filter at it (tooFastRestarts).
  double pair_max_speed = 12.0;
  // The omni camera sees all around: `unseen_frames` frames in a row without the ball while the
  // estimate lies within `unseen_range_m` of the robot make the estimate invalid until a sighting
  // agrees or the filter restarts (the ball was put back or kicked away out of sight; a ball
  // hidden behind a robot is not reported meanwhile). 0: off, m.
  double unseen_range_m = 6.0;
  int unseen_frames = 2;
  // BallTracker: a frame is fused again with the robot's newest pose for its time until it is
  // this old (0: fused once, at the first estimate after it arrived), s.
  double settle_s = 0.3;
  // BallTracker: the pose at a frame's time takes the next line frame's correction into account
  // (`smoothedPose`), once that frame has arrived.
  bool smooth_pose = true;
};

enum class BallRejection : std::uint8_t {
  kNone = 0,
  kNotVisible,
  kNotFinite,
  kOutOfOrder,
  kTooFar,
  kOutlier,
  kPoseUnconfirmed,
};
const char* toString(BallRejection r);

class BallFilter {
 public:
  explicit BallFilter(BallFilterParams params = {});

  // Fuses a visible sighting with the robot's state at the sighting's utime. `confirmed_after`:
  // the next line frame after the sighting confirmed the pose (BallTracker), see
  // pose_max_unconfirmed_s.
  BallRejection update(const perception::BallSighting& sighting, const EkfState& robot,
                       bool confirmed_after = true);
  // A frame at `t` that did not see the ball, the robot's state at that time (unseen_range_m).
  // Returns kPoseUnconfirmed when the pose was not used (pose_max_unconfirmed_s), else kNone.
  BallRejection missed(Utime t, const EkfState& robot);
  // Whether the robot's pose at `t` was confirmed recently enough (pose_max_unconfirmed_s).
  bool poseConfirmed(Utime t, const EkfState& robot) const;
  // Unseen at `t` for longer than max_age_s.
  bool expiredAt(Utime t) const;
  // Times the estimate was made invalid by frames that should have seen it.
  std::uint64_t unseenInvalidations() const { return unseen_invalidations_; }
  // The estimate at `t` (moved on with friction); valid only within max_age of the last sighting.
  perception::BallEstimate estimate(Utime t) const;
  // Maps the estimate (and the outliers kept for a restart) through the field's point symmetry:
  // the robot's pose was moved to its twin, and every sighting fused so far with it.
  void mirrorThroughCentre();
  bool initialized() const { return initialized_; }
  // The ball is taken to be at rest (rest_acceleration_density).
  bool resting() const { return resting_; }
  // Restarts at a confident far sighting, and restarts with the velocity of an outlier pair.
  std::uint64_t restartsFar() const { return restarts_far_; }
  std::uint64_t restartsWithVelocity() const { return restarts_with_velocity_; }
  // Restarts at a sighting because fusing it would have made the ball faster than
  // pair_max_speed (a jump of the robot's uncertain pose, not of the ball).
  std::uint64_t tooFastRestarts() const { return too_fast_restarts_; }

 private:
  // State (x, y, vx, vy) moved to `t`.
  void predict(Utime t, Eigen::Vector4d& x, Eigen::Matrix4d& p) const;
  // (Re)starts at a sighting `z` (field frame, covariance `r`) at `t`, with the velocity from the
  // previous outlier when params allow.
  void restart(Utime t, const Eigen::Vector2d& z, const Eigen::Matrix2d& r);
  // Velocity (and its covariance, and the position-velocity covariance) of a straight path
  // through the row of outliers (those at most pair_max_age_s old) and `z`; false when there
  // are none, the path is faster than pair_max_speed, or the sightings do not lie on it.
  bool fitRow(Utime t, const Eigen::Vector2d& z, const Eigen::Matrix2d& r, Eigen::Vector2d& v,
              Eigen::Matrix2d& pv, Eigen::Matrix2d& pxv) const;

  BallFilterParams params_;
  bool initialized_ = false;
  Utime utime_ = 0;
  Utime last_seen_ = 0;
  int outliers_in_row_ = 0;
  int missed_in_row_ = 0;
  std::uint64_t unseen_invalidations_ = 0;
  // The estimate is contradicted (an outlier sighting, frames that should have shown the ball
  // and did not, or a restart after it expired awaiting a sighting that agrees): not reported
  // valid until a sighting agrees or the filter restarts. An outlier never clears it.
  bool contradicted_ = false;
  // The resting model (rest_acceleration_density) is in use.
  bool resting_ = false;
  Eigen::Vector4d x_ = Eigen::Vector4d::Zero();
  Eigen::Matrix4d p_ = Eigen::Matrix4d::Identity();
  // The outlier sightings in a row (field frame), for the velocity of a restart.
  struct Outlier {
    Utime utime = 0;
    Eigen::Vector2d z = Eigen::Vector2d::Zero();
    Eigen::Matrix2d r = Eigen::Matrix2d::Identity();
  };
  std::vector<Outlier> outliers_;
  std::uint64_t restarts_far_ = 0;
  std::uint64_t restarts_with_velocity_ = 0;
  std::uint64_t too_fast_restarts_ = 0;
};

}  // namespace fieldline::fusion
