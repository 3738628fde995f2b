// The team picture: every robot's pose and ball, aged and predicted to now, and a team ball fused
// from the robots' own ball estimates, covariance-weighted, inside a consistency gate. A ball
// contradicted by a sighting made well after its own last one is superseded (the ball moved
// since) and left out; of the rest, the largest group of mutually consistent balls wins, so a
// mislocalized teammate's ball (confidently in the wrong place) is left out rather than averaged
// in. Among groups of equal size the one that continues the previous team ball wins, and a lone
// group whose ball is the previous team ball's mirror image through the centre spot (its reporters
// sit on their symmetric twin) is left out. Plain library: every time is on this robot's clock and
// comes in as an argument.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "common/perception/estimates.hpp"
#include "common/perception/team.hpp"
#include "common/time/clock.hpp"

namespace fieldline::teamcomm {

struct PictureOptions {
  // A robot is present while its newest report is at most this old.
  Utime present_timeout_us = 500'000;
  // A ball its reporter last saw longer ago than this is not used, and a team ball none of whose
  // reporters saw it this recently is not claimed: fusion's own-ball rule (ball.max_age_s). 1 s
  // until 2026-12-06 let the team ball outlive every own ball by up to half a second.
  Utime ball_timeout_us = 500'000;
  // Predictions reach at most this far (beyond it, positions are held).
  Utime max_prediction_us = 500'000;
  // Unmodelled acceleration of robots and ball: position uncertainty grows by this times the
  // prediction time, m/s.
  double robot_speed_sigma_mps = 0.5;
  // The ball's: its estimate carries a velocity (fusion's filter, whose velocity sigma at rest is
  // about 0.1 m/s); 1.0 made a resting ball's covariance five times its error over the 50-100 ms
  // between a BALL_STATE and the picture (NEES in band 0.50 -> 0.68 in hidden_ball at 0.3).
  double ball_speed_sigma_mps = 0.3;
  // ... of a ball reported slower than ball_rest_speed_mps: at rest (fusion's resting model),
  // whose velocity sigma is a few cm/s. 0.3 made a resting ball's team covariance 2.5 times its
  // error (kidnap, hidden_ball: NEES below its band a quarter of the time). m/s.
  double ball_rest_speed_sigma_mps = 0.03;
  double ball_rest_speed_mps = 0.15;
  // Every BALL_STATE's covariance holds this squared times its velocity's outer product (fusion's
  // ball.stamp_sigma_s, which this must equal): the stamps' error, taken as common to the
  // reporters. The team ball weighs its reporters without it (it says nothing about who sees
  // the ball better) and holds it once (fusing does not shrink it). 0: off, s.
  double ball_stamp_sigma_s = 0.01;
  // Floor of a ball's sigma along its reporter's line of sight: this times the range squared,
  // m per m^2 (a pixel's footprint on the floor grows with the range squared). Fusion's filter
  // shrinks a ball's covariance with every frame as if each frame's error were new, but a robot
  // standing still sees a resting ball on the same pixels every frame: its error is a bias that
  // no number of frames averages away (hidden_ball: robot 3 standing 3.3 m away 2.5 cm off with
  // a 1.3 cm sigma, robot 1 at 2.5 m 1 cm off; the one turning on the spot 3-4 mm), and fusing
  // it at its claimed weight pulled the team ball off the best robot's. 1.5 mm at 1 m, 6 mm at
  // 2 m, 1.35 cm at 3 m. 0: off.
  double ball_radial_floor_per_m2 = 0.0015;
  // A view is static (the floor applies) while the ball rests (ball_rest_speed_mps) and its
  // reporter moves slower than this, m/s, and turns slower than this, rad/s: a robot that moves
  // or turns sees the ball on other pixels every frame, and its filter's averaging is right.
  double static_speed_mps = 0.05;
  double static_turn_radps = 0.05;
  // Squared Mahalanobis distance within which two balls agree (chi-square, 2 dof, 99 %).
  double gate_chi2 = 9.21;
  // Floor of a ball's position variance, m^2 (no estimate is better than 5 mm; a resting ball
  // seen from 1-2 m is 4-7 mm off, and the 2 cm floor until 2026-12-06 made its covariance four
  // times too wide).
  double min_ball_variance = 0.000025;
  // The previous team ball decides ties and exposes mirrored balls for this long after it was
  // last fused, µs.
  Utime track_timeout_us = 3'000'000;
  // A ball whose reporter last saw it this much longer ago than another reporter saw a ball that
  // contradicts it (outside the gate) is superseded and left out: the ball has moved since (a
  // kick, a put-back) and its reporter has not seen it since; its estimate stays valid for a
  // while (fusion's max_age) but is no longer the ball. A put-back's first confident sighting
  // comes at least three frames (100 ms; fusion's restart_after_outliers) after the last one at
  // the old place; robots that see the ball at the same time differ by a frame plus a packet
  // interval in our reports (up to 85 ms: a plain disagreement, the larger group wins). 100 ms
  // until 2026-12-06 let the old place win the first picture after a put-back; 50 ms let a
  // teammate's fresher packet supersede balls seen at the same time. 0: off, µs.
  Utime superseded_after_us = 90'000;
  // Only a confident sighting supersedes: both of its position sigmas at most this, m (fusion's
  // ball.restart_max_sigma_m).
  double supersede_max_sigma_m = 0.15;
  // The team ball carries what it knew about a resting ball: the previous team ball (at rest,
  // its sigma grown by carry_speed_sigma_mps per second) and the winning group's ball (at rest)
  // are combined by covariance intersection while they agree (gate_chi2) and the previous one
  // holds a robot's sightings that the group does not (a robot's newer ball has its older ones in
  // it): the better one wins, or a mix whose covariance is never narrower than either (each
  // picture fuses the same reporters' filters again: a Kalman update would count them twice). A
  // rolling ball is not carried (its carried velocity lags a kick). Replays of 10 match and 17
  // other recordings (docs/log/2026-12-06-team-ball.md, "Session 6"): kidnap 1-8 % better, the
  // match -2 % to +0.3 %; a growth of 0.03 m/s (fusion's resting model) gained more in kidnap but
  // took the team NEES in band below 0.85 on four recordings (the carried covariance, a near
  // robot's, wider than its error).
  bool carry_track = true;
  double carry_speed_sigma_mps = 0.1;
};

// A robot's ball, predicted to the picture's time, as the team ball's fusion sees it.
struct BallCandidate {
  int robot_id = 0;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  // Its reporter's pose may be its symmetric twin.
  bool twin_ambiguous = false;
  // When its reporter last saw it (our clock).
  Utime last_seen = 0;
};

// One robot's report, already converted to our clock.
struct Report {
  perception::RobotEstimate robot;
  perception::BallEstimate ball;
  // When it arrived (our clock): presence runs on this, not on the sender's stamps.
  Utime received_utime = 0;
};

struct TeamBallResult {
  bool valid = false;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  // Robot ids (1..6) whose balls were fused, and those whose valid balls the gate left out.
  std::vector<int> used;
  std::vector<int> rejected;
  // Of the rejected: those whose balls lay at the previous team ball's mirror image, and those
  // superseded by a fresher contradicting sighting (PictureOptions::superseded_after_us).
  std::vector<int> mirrored;
  std::vector<int> superseded;
};

class TeamPicture {
 public:
  TeamPicture(int own_robot_id, PictureOptions options = {});

  // Our own estimates (from ROBOT_STATE / BALL_STATE) and a teammate's (from a packet).
  void setReport(int robot_id, const Report& report);
  // Forgets a robot (e.g. its clock offset was reset).
  void clear(int robot_id);
  // The robot's latest report, or null.
  const Report* report(int robot_id) const;

  // Poses, balls and team ball at `now`. Link statistics are left for the caller. The team ball
  // is remembered for the next picture (ties, mirror images).
  perception::TeamState picture(Utime now, TeamBallResult* team_ball = nullptr);

 private:
  int own_robot_id_;
  PictureOptions options_;
  std::array<std::optional<Report>, perception::kTeamSize> reports_{};
  // The last valid team ball.
  struct Track {
    Utime utime = 0;
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
    Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
    // The robots whose sightings it holds (sorted).
    std::vector<int> sources;
  };
  std::optional<Track> track_;

  // The winning group's fused ball, its size and whether it continues the previous team ball.
  struct Choice {
    TeamBallResult ball;
    std::size_t size = 0;
    bool continues = false;
  };
  // The teammate's pose (and ball) at `now` into `out`; its ball as a candidate when usable.
  std::optional<BallCandidate> updateTeammate(const Report& report, Utime now,
                                              perception::TeammateState& out) const;
  // The report's ball at `position` (predicted ball_dt s), seen from `reporter` (the robot's
  // position), with its grown, floored covariance.
  BallCandidate ballCandidate(const Report& report, const Eigen::Vector2d& position,
                              const Eigen::Vector2d& reporter, double ball_dt) const;
  // Removes the superseded candidates; their robot ids.
  std::vector<int> leaveOutSuperseded(std::vector<BallCandidate>& candidates) const;
  // The previous team ball carried to now, while it is recent enough to judge by.
  std::optional<BallCandidate> trackAt(Utime now) const;
  // The winning group's ball combined with the previous team ball carried to now (carry_track);
  // the robots whose sightings the result holds.
  std::vector<int> carryTrack(Utime now, TeamBallResult& best) const;
  Choice largestConsistentGroup(const std::vector<BallCandidate>& candidates,
                                const std::optional<BallCandidate>& track) const;
  void rejectTheOthers(Choice& choice, const std::vector<BallCandidate>& candidates,
                       const std::optional<BallCandidate>& track,
                       const std::vector<int>& superseded) const;
};

}  // namespace fieldline::teamcomm
