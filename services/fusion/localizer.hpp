// Localization on top of the delay-aware filter: layer 1 (odometry) moves it, layer 2 (the line
// matcher's correction of each frame) corrects it, layer 3 (FIELD_FEATURES hypotheses) is fused
// when consistent with it. When the robot is lost (start-up, or carried off: the line points no
// longer fit and confident features contradict the estimate) it keeps several hypotheses, from
// the features and from a coarse search over the field, tests them against the following frames'
// line points and commits to one (SEARCHING -> TRACKING). The field's symmetric twin of a pose
// fits the lines equally well: continuity with the last trusted estimate decides, or a start-up
// prior, and the result is reported as ambiguous when only the prior decided; teammates' balls
// (addTwinVote) then confirm it or move it to its twin.
//
// Plain library: the matcher comes in as two functions, time as arguments.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/perception/estimates.hpp"
#include "common/perception/field_features.hpp"
#include "common/perception/line_points.hpp"
#include "common/perception/obstacles.hpp"
#include "common/robot/robot_params.hpp"
#include "services/fusion/current_contact.hpp"
#include "services/fusion/history.hpp"
#include "services/fusion/line_matcher.hpp"
#include "services/fusion/odometry_layer.hpp"
#include "services/fusion/team_twin.hpp"

namespace fieldline::fusion {

// What the localizer needs of layer 2 (LineMatcher::correct and LineMatcher::cost).
struct MatcherFunctions {
  std::function<PoseCorrection(std::span<const perception::LinePoint>, const geometry::Pose2&)>
      correct;
  std::function<double(std::span<const perception::LinePoint>, const geometry::Pose2&)> cost;
  // Optional: poses over the whole field that fit the points, best first (LineMatcher::
  // globalSearch). Without it the localizer scores its own coarse grid with cost().
  std::function<std::vector<PoseCorrection>(std::span<const perception::LinePoint>)> global_search;
};

// Which of two symmetric poses to believe at start-up, when nothing else tells.
enum class StartPrior { kOwnHalf, kNone };

struct LocalizerParams {
  FilterParams filter;
  OdometryNoise odometry;
  // A frame whose corrected mean matching cost is at most this is a trusted correction, m.
  double accept_cost_m = 0.10;
  // A frame whose cost at the estimate is above this contradicts it, m.
  double lost_cost_m = 0.16;
  // Contradicting frames in a row before the robot counts as lost.
  int lost_frames = 2;
  // A frame with at least this many points contradicts the estimate (cost above lost_cost_m)
  // even when it gives no valid correction from it.
  std::size_t contradict_min_points = 60;
  // Well-matching frames refused by the filter's gate in a row before the filter is reset to
  // the frame's correction.
  int gated_frames_reset = 3;
  // A gated frame is taken as a slip (SlipModel) only when the frame before it was gated too,
  // with a disagreement within these of its own: one frame alone may be an aliased match along a
  // line (the kill drill saw a single 25 cm one applied). A collision keeps twisting the robot
  // between frames (up to 0.5 rad per frame), so the default tolerance is wide. m, rad.
  double slip_confirm_m = 1.0;
  double slip_confirm_rad = 1.2;
  // A single gated frame is taken as a slip at once when its heading disagrees by at least this:
  // collisions twist the robot (up to 2 rad in 0.4 s), aliased matches along a line shift it. rad.
  double slip_single_frame_rad = 0.15;
  // ... or when the lines pin its disagreement down: an aliased match slides along the
  // direction the frame says little about (its covariance is long there), a push moves the robot
  // against lines the frame sees. When the frame's position sigmas differ by at least
  // `slip_pinned_ratio`, only the disagreement across its long axis is tested, otherwise all of
  // it; beyond `slip_pinned_chi2` (squared Mahalanobis distance with the estimate's and the
  // frame's covariance) the frame is a slip at once. Ratio 0: off.
  double slip_pinned_ratio = 2.0;
  double slip_pinned_chi2 = 10.83;
  // A frame whose heading was weighted down against the gyro's (SlipModel::gyro_heading_chi2)
  // is confirmed by the next frame when that one disagrees in heading by the same within this:
  // the next frame's heading is taken in full (a heading the gyro lost, e.g. saturated in a
  // collision, is put right). rad.
  double heading_confirm_rad = 0.05;
  // Frames a hypothesis must have been tested on before committing to it.
  int commit_frames = 2;
  // Twin guard. A committed pose becomes the continuity reference of the next loss only after
  // this many accepted line corrections since the commit: a pose lost again before that was
  // never confirmed, and the reference stays the one from before it (carried by odometry).
  int trust_frames = 5;
  // The twin is resolved by continuity only when the hypothesis and its twin differ in their
  // distance to the reference by at least this (position m + 0.2 m/rad heading); otherwise, or
  // when the reference cannot be carried to the hypothesis's time (older than the dead
  // reckoning's history), the commit is reported as ambiguous.
  double twin_margin_m = 0.5;
  // ... or this many standard deviations of the reference's position (the filter's covariance
  // at the loss: long odometry-only stretches and contacts make it uncertain), or the distance
  // a push may have carried the robot unseen since the last accepted correction (the filter's
  // SlipModel: base_m + max_speed * time; a collision during 0.6 s without frames moved a robot
  // 0.7 m and turned it 1.2 rad while its wheels said 1.1 m the other way), whichever is larger.
  double twin_margin_sigmas = 3.0;
  // Teammates' balls (TeamBallVoter, at most one vote per team picture) decide the twin after
  // this many votes of one kind in a row: an ambiguous pose is confirmed, or moved to its twin; a
  // certain pose that as many votes contradict becomes ambiguous first (it takes a second run to
  // move it). 0: off.
  int twin_vote_run = 3;
  // A vote more than this after the one before starts a new run, µs.
  Utime twin_vote_gap_us = 2'000'000;
  // A line or feature frame newer than the newest odometry waits until odometry reaches its time
  // (a starved motor bridge delivers seconds of samples late, at once): matched earlier, it would
  // be matched against a pose the held velocity extrapolated, which a turn makes wrong, and could
  // lose the robot or commit it to a wrong place. At most this many frames wait; beyond, the
  // oldest is dropped (counted "lines_odometry_stalled", "features_odometry_stalled"). The
  // wait is bounded in time too (max_wait_us), so 40 frames hold 0.4 s of 30 Hz lines plus 30 Hz
  // features with room to spare.
  std::size_t max_waiting_frames = 40;
  // A waiting frame older than this (of `now`), or any frame while no odometry arrived for this
  // long (bridge dead, serial unplugged), is processed at once, the filter predicting with the
  // held velocity: without odometry the pose still gets vision's corrections, µs.
  Utime max_wait_us = 400'000;
  // The best hypothesis must beat every other (but its twin) by this mean cost, m.
  double commit_margin_m = 0.02;
  // Layer 3: a feature hypothesis within these of the estimate is fused, m / rad.
  double feature_gate_m = 0.6;
  double feature_gate_rad = 0.4;
  // A confident feature hypothesis further than this from the estimate (and its twin) contradicts
  // it, m; at least feature_gate_m (the config refuses less: a fused hypothesis would count as a
  // contradiction).
  double contradict_m = 1.0;
  // Calibration of a layer-2 correction's covariance (the matcher's Hessian is optimistic where
  // the points are few, unevenly spread or partly mismatched): the Hessian's covariance times
  // `correction_inflation`, plus floors, plus standard deviations that grow with the frame's
  // matching cost (a frame that fits worse is trusted less), m and rad.
  double correction_floor_m = 0.008;
  double correction_floor_rad = 0.015;
  double correction_inflation = 0.6;
  // Added position sigma per metre of mean matching cost (1), heading sigma per metre (rad/m).
  double correction_cost_gain = 0.0;
  double correction_cost_gain_rad = 0.0;
  // Uncertainty of a frame's stamp, s: its pose is the one the robot had up to this much before
  // or after, so the covariance grows by this squared times (vx, vy, omega)(vx, vy, omega)^T at
  // the frame's time (frames taken while turning fast are several degrees off more often).
  double correction_stamp_sigma_s = 0.008;
  // Uncertainty of a pose committed after global localization (start-up, kidnap): the
  // hypothesis's covariance floored by these, m and rad.
  double commit_sigma_m = 0.05;
  double commit_sigma_rad = 0.03;
  // The reported covariance (ROBOT_STATE) adds what the filter does not model: floors, and the
  // odometry stamp's uncertainty times the velocity (a pose at the wrong instant), m, rad, s.
  double state_floor_m = 0.0;
  double state_floor_rad = 0.0;
  double stamp_sigma_s = 0.003;
  // No VISION_LINES for this long: status ODOMETRY_ONLY, µs.
  Utime vision_timeout_us = 1'000'000;
  // TRACKING promises a pose to steer on: while the reported position uncertainty (the largest
  // standard deviation of x, y) is beyond this, the status is ODOMETRY_ONLY. A push or slip the
  // wheels did not see widens the covariance before the next frames can correct the pose (the
  // match at load 7-12 saw a robot 0.66 m off for 0.1 s with sigma >= 0.25 m, still TRACKING;
  // at load 30-50 one 0.5 m off with sigma about 0.14 m): 4 sigma within 0.5 m. m; 0: off.
  double tracking_max_sigma_m = 0.12;
  // After a gated reset (the filter restarted from a frame that disagreed with it), the status
  // is SEARCHING until this many later line frames were accepted: the frames that forced the
  // reset need not agree with each other (in a collision's twist the match ran 0.53 m and
  // 1.35 rad off with a small covariance, TRACKING, until the next frames lost it). 0: off.
  int reset_confirm_frames = 2;
  // Coarse search: grid step, m; headings per turn; points used per pose.
  double search_step_m = 0.5;
  int search_headings = 24;
  int search_points = 60;
  std::size_t max_hypotheses = 10;
  // After losing track (a collision twisted the robot, not a kidnap), for this long the pose
  // before the loss, carried on by odometry, seeds hypotheses at these heading offsets (multiples
  // of the step up to the count each side): the nearby answer is found in the next frame instead
  // of waiting for the global search to tell it from look-alike places, s, rad.
  double local_search_s = 1.0;
  double local_search_step_rad = 0.35;
  int local_search_steps = 4;
  // In contact (ContactModel), a frame that gives no good correction from the estimate (the
  // robot was twisted further than the matcher reaches) is matched again from the estimate
  // turned by multiples of local_search_step_rad, up to this many each side, and the best good
  // correction is taken at once as a slip; 0: off. With `twist_search_always` every such frame is
  // searched, contact seen or not.
  int contact_search_steps = 3;
  bool twist_search_always = true;
  // The search also while the heading comes from the gyro (which sees a twist).
  bool twist_search_with_gyro = true;
  // Frames with fewer points are not searched (a few points fit some heading by chance).
  std::size_t contact_search_min_points = 30;
  // Contact evidence from the motor currents in ODOMETRY (current_contact.hpp); off by default.
  CurrentContactParams current_contact;
  // Half extents of the area searched (the carpet), m.
  double search_half_length_m = 10.0;
  double search_half_width_m = 6.5;
  StartPrior start_prior = StartPrior::kOwnHalf;
  // A fusion restarted within this of its last saved pose (pose_memory.hpp: the file, the
  // process's --state-file) resumes from it: the saved pose is the twin's continuity reference of
  // the first commit, widened by what the robot may have moved unseen meanwhile (the filter's
  // SlipModel: base_m + max_speed * the gap), s; 0: never (every start is a start-up).
  double resume_max_age_s = 5.0;
};

struct LocalizerCounters {
  std::map<std::string, std::uint64_t> rejected;
  std::uint64_t corrections = 0;
  std::uint64_t feature_updates = 0;
  std::uint64_t lost = 0;
  std::uint64_t commits = 0;
  std::uint64_t searches = 0;
  std::uint64_t resets = 0;
  // Corrections that revealed a slip or push odometry did not see (SlipModel).
  std::uint64_t slips = 0;
  // Of those, single frames taken at once because the lines pinned the disagreement down.
  std::uint64_t pinned_slips = 0;
  // ... or because the robot was in contact (ContactModel).
  std::uint64_t contact_slips = 0;
  // Commits where nothing resolved the twin (ambiguous() was set), and gated resets refused
  // because the frame's pose lay nearer the estimate's twin than the estimate.
  std::uint64_t ambiguous_commits = 0;
  std::uint64_t twin_resets_refused = 0;
  // What teammates' balls did to the twin (addTwinVote): confirmed an ambiguous pose, moved it to
  // its twin, made a certain pose ambiguous.
  std::uint64_t twin_confirmed_by_team = 0;
  std::uint64_t twin_flips_by_team = 0;
  std::uint64_t twin_doubted_by_team = 0;
  // Frames that waited for odometry to reach their time (max_waiting_frames).
  std::uint64_t frames_waited = 0;
  // Starts that resumed from a saved pose (resumeFrom).
  std::uint64_t resumed = 0;
  // Frames whose correction came from the twist search (contact_search_steps).
  std::uint64_t twist_searches = 0;
  // Frames whose heading was weighted down against the gyro's, and frames whose heading a
  // second frame confirmed (SlipModel::gyro_heading_chi2, heading_confirm_rad).
  std::uint64_t headings_weighted_down = 0;
  std::uint64_t headings_confirmed = 0;
  // VISION_OBSTACLES frames that showed an obstacle touching the robot.
  std::uint64_t contact_frames = 0;
  // Odometry samples whose currents showed a contact (CurrentContactDetector).
  std::uint64_t current_contacts = 0;
  // Odometry steps whose heading came from the gyro.
  std::uint64_t gyro_steps = 0;
};

class Localizer {
 public:
  Localizer(const robot::RobotParams& robot, LocalizerParams params, MatcherFunctions matcher);

  // Layer 1. Returns false when the sample gave no movement (first, refused). Its currents, when
  // it carries them, are contact evidence (LocalizerParams::current_contact); bad currents are
  // refused and counted ("current_not_finite", "current_absurd"), the ticks still count. Its
  // gyro rotation, when it carries one and the robot has a gyro, turns the heading
  // (OdometryNoise::use_gyro); a non-finite or absurd one is counted ("gyro_not_finite",
  // "gyro_absurd") and the wheels' heading is used.
  bool addOdometry(const OdometrySample& sample, Utime now);
  // Layer 2 (and hypothesis testing while lost) on one frame's line points at its utime.
  void addLines(std::span<const perception::LinePoint> points, Utime utime, Utime now);
  // Layer 3.
  void addFeatures(const perception::FieldFeatures& features, Utime utime, Utime now);
  // Contact evidence: a frame whose nearest obstacle lies within params.filter.contact.distance_m
  // of the robot's centre. While in contact the pose's process noise grows (ContactModel) and a
  // well-matching line frame beyond the gate is taken at once as a slip. A frame with a
  // non-finite or negative distance is refused and counted ("obstacles_not_finite").
  void addObstacles(const perception::ObstacleSightings& sightings, Utime now);
  // A vote of teammates' balls on the twin (TeamBallVoter::vote on a ball sighting, with the pose
  // at its time), in the sightings' time order. Acts only while tracking, after
  // LocalizerParams::twin_vote_run votes of one kind in a row. `utime`: the sighting's.
  void addTwinVote(TwinVote vote, Utime utime);
  // The process restarted: `pose` (with `covariance`) is where it was at `saved_utime` (this
  // clock), its twin undecided then when `twin_ambiguous`. The first odometry sample anchors it:
  // carried by dead reckoning from there, it is the continuity reference of the next commit, its
  // margin widened by the SlipModel's reach over the gap before that sample. A commit it decides
  // is ambiguous() when the saved pose was (as before the restart: only the start-up prior and
  // continuity since told the twins apart). The start-up prior does not hold after a restart (the
  // robot may be anywhere): while neither continuity nor teammates' balls decided the twin, the
  // reported status is SEARCHING, not TRACKING.
  void resumeFrom(const geometry::Pose2& pose, const Eigen::Matrix3d& covariance, Utime saved_utime,
                  bool twin_ambiguous);
  // True once resumeFrom was called.
  bool restarted() const { return restarted_; }
  // True while contact evidence covers `t`.
  bool inContact(Utime t) const { return filter_.inContact(t); }

  // The estimate at the newest odometry time (what ROBOT_STATE carries); `now` decides
  // ODOMETRY_ONLY.
  perception::RobotEstimate estimate(Utime now) const;
  // The filter's state at `t` (for the ball); empty while no pose is known.
  std::optional<EkfState> stateAt(Utime t) const;
  // The covariance of (x, y, phi) to report for a state: the filter's plus the floors and the
  // stamp's uncertainty (LocalizerParams).
  Eigen::Matrix3d reportedCovariance(const EkfState& s) const;

  perception::LocalizationStatus mode() const { return mode_; }
  // The status to report with a pose of this reported covariance: mode(), ODOMETRY_ONLY when no
  // lines arrived for vision_timeout_us or the position is more uncertain than
  // tracking_max_sigma_m allows.
  perception::LocalizationStatus reportedStatus(const Eigen::Matrix3d& covariance, Utime now) const;
  // True when no odometry sample arrived for LocalizerParams::max_wait_us (or none ever).
  bool odometrySilent(Utime now) const {
    return last_odometry_arrival_ == 0 || now - last_odometry_arrival_ > params_.max_wait_us;
  }
  // True while the committed pose was chosen over its twin by the start-up prior only, or when
  // no trusted reference told them apart (LocalizerParams::twin_margin_m), or teammates' balls
  // contradicted a certain pose; until teammates' balls confirm or move it (addTwinVote) or the
  // next commit.
  bool ambiguous() const { return ambiguous_; }
  // Mean matching cost of the last line frame at the estimate, m (negative: none yet).
  double lastCost() const { return last_cost_; }
  double lastCorrectionM() const;
  double lastCorrectionRad() const;
  std::size_t hypothesisCount() const { return hypotheses_.size(); }
  const LocalizerCounters& counters() const { return counters_; }
  const DelayedFilter& filter() const { return filter_; }
  // The filter's estimate of the gyro's bias [rad/s] (0 while no pose is known).
  double gyroBias() const { return filter_.initialized() ? filter_.current().x[kGyroBias] : 0.0; }
  // The filter's params with the gyro's bias walk from the robot file.
  static FilterParams withGyro(FilterParams params, const robot::RobotParams& robot);

 private:
  struct Hypothesis {
    Utime utime = 0;
    geometry::Pose2 pose;
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
    // As a continuity reference: how far the robot may have moved unseen by odometry since the
    // state's last accepted correction (SlipModel's bound for that time), m.
    double unseen_m = 0.0;
    // As a continuity reference: its own twin was undecided (a saved pose that was ambiguous), so
    // a commit it decides is ambiguous too.
    bool twin_ambiguous = false;
    // Mean cost over the frames it was tested on.
    double cost_sum = 0.0;
    int frames = 0;
    double meanCost() const { return frames > 0 ? cost_sum / frames : 1e9; }
  };

  void count(const std::string& reason) { ++counters_.rejected[reason]; }
  // Movement (robot frame at t1) from t1 to t2 by dead reckoning.
  std::optional<geometry::Movement> motionBetween(Utime t1, Utime t2) const;
  void processLines(std::span<const perception::LinePoint> points, Utime utime, Utime now);
  void processFeatures(const perception::FieldFeatures& features, Utime utime, Utime now);
  // While searching: each finite feature hypothesis and its twin kept as hypotheses.
  void keepFeatureHypotheses(const perception::FieldFeatures& features, Utime utime);
  // Newest odometry time known (0: none).
  Utime newestOdometry() const {
    return dead_reckoning_.empty() ? 0 : dead_reckoning_.newest().utime;
  }
  // A frame waits when odometry has not reached it yet (and is not silent), or behind others
  // already waiting, so that frames are processed in time order.
  bool mustWait(Utime utime, Utime now) const {
    return (utime > newestOdometry() && !odometrySilent(now)) || !waiting_.empty();
  }
  // Frames waiting for odometry, processed in time order once it reaches them.
  void processWaiting(Utime now);
  // The frame queue of addLines and addFeatures: a frame from the future is counted
  // (`from_future`) and dropped; one that odometry has not reached yet waits (its copy made by
  // `make_waiting`); true when the frame is to be processed now.
  template <typename MakeWaiting>
  bool admitFrame(Utime utime, Utime now, const char* from_future, MakeWaiting make_waiting);
  void trackLines(std::span<const perception::LinePoint> points, Utime utime, Utime now);
  // Twisted in contact beyond what the matcher reaches from the estimate (correction `c` not
  // good): the heading searched (contact_search_steps), unless the gyro's heading rules it out.
  std::optional<PoseCorrection> searchTwist(std::span<const perception::LinePoint> points,
                                            const EkfState& guess, const PoseCorrection& c,
                                            bool contact) const;
  // What a frame's disagreement `offset` (its measurement `z`) with the estimate `guess` says of
  // a slip: confirmed by the gated frame before, pinned down by the lines, or a twist.
  struct SlipEvidence {
    bool confirmed = false;
    bool pinned = false;
    bool twisted = false;
  };
  SlipEvidence slipEvidence(const Eigen::Vector3d& offset, const PoseMeasurement& z,
                            const EkfState& guess) const;
  // The filter restarted at the frame's pose (after gated_frames_reset gated frames in a row).
  void resetToFrame(const PoseCorrection& c, const EkfState& guess, Utime utime);
  // A good match the filter refused (`rejection`): counted; gated frames in a row reset the
  // filter to the frame's pose, unless they put the robot nearer the estimate's twin (then it is
  // lost and searches the frame's points).
  enum class RejectedLines { kKept, kReset, kSearched };
  RejectedLines onRejectedLines(Rejection rejection, const Eigen::Vector3d& offset,
                                const PoseCorrection& c, const EkfState& guess,
                                std::span<const perception::LinePoint> points, Utime utime);
  void searchLines(std::span<const perception::LinePoint> points, Utime utime);
  void coarseSearch(std::span<const perception::LinePoint> points, Utime utime);
  void localSearch(std::span<const perception::LinePoint> points, Utime utime);
  // The best good correction from `guess` turned by up to `steps` heading steps each side
  // (not the unturned guess itself).
  std::optional<PoseCorrection> searchHeadings(std::span<const perception::LinePoint> points,
                                               const geometry::Pose2& guess, int steps) const;
  void addHypothesis(const Hypothesis& h);
  void becomeLost(Utime utime);
  void commit(const Hypothesis& h);
  // Picks h or its twin: the one nearer the reference pose (continuity) or the start prior.
  Hypothesis resolveTwin(const Hypothesis& h, const Hypothesis* twin);
  Eigen::Matrix3d floored(const Eigen::Matrix3d& c) const;
  // A layer-2 correction's covariance as the filter takes it (LocalizerParams calibration).
  // `velocity`: the robot's (vx, vy, omega) at the frame's time (field frame).
  Eigen::Matrix3d correctionCovariance(const PoseCorrection& c,
                                       const Eigen::Vector3d& velocity) const;

  robot::RobotParams robot_;
  LocalizerParams params_;
  MatcherFunctions matcher_;
  OdometryLayer odometry_;
  CurrentContactDetector currents_;
  DelayedFilter filter_;
  // Dead-reckoned (x, y, unwrapped phi) in the odometry frame at each odometry time.
  TimedChannel<Eigen::Vector3d> dead_reckoning_;
  Eigen::Vector3d odometry_pose_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d last_velocity_ = Eigen::Vector3d::Zero();

  perception::LocalizationStatus mode_ = perception::LocalizationStatus::kUnknown;
  bool ambiguous_ = false;
  // The last commit's twin was decided by neither continuity nor teammates' balls (the start-up
  // prior or nothing did); cleared when the team confirms or moves it.
  bool twin_undecided_ = false;
  // Team ball votes of one kind in a row (addTwinVote), and the utime of the newest vote.
  int same_run_ = 0;
  int twin_run_ = 0;
  Utime last_vote_utime_ = 0;
  std::vector<Hypothesis> hypotheses_;
  // The last trusted pose (when tracking was lost), for continuity.
  std::optional<Hypothesis> reference_;
  // A saved pose (resumeFrom) waiting for the first odometry sample to anchor it.
  std::optional<Hypothesis> pending_resume_;
  bool restarted_ = false;
  // Makes pending_resume_ the continuity reference at the first dead-reckoning entry.
  void anchorResume();
  struct WaitingFrame {
    Utime utime = 0;
    std::vector<perception::LinePoint> points;
    std::optional<perception::FieldFeatures> features;
  };
  std::vector<WaitingFrame> waiting_;
  // Accepted line corrections since the last commit (LocalizerParams::trust_frames).
  int good_since_commit_ = 0;
  // Accepted line frames still needed to confirm a gated reset (reset_confirm_frames).
  int reset_unconfirmed_ = 0;
  int bad_frames_ = 0;
  int contradictions_ = 0;
  int gated_in_row_ = 0;
  // Disagreement (frame correction - estimate) of the previous line frame when the gate refused
  // it; empty after an accepted or unmatched frame.
  std::optional<Eigen::Vector3d> gated_offset_;
  // Heading disagreement of the previous line frame when its heading was weighted down; empty
  // otherwise.
  std::optional<double> weighted_heading_offset_;
  double last_cost_ = -1.0;
  // utime the filter was last (re)started at (commit or gated reset; 0: never).
  Utime restart_utime_ = 0;
  Utime last_lines_arrival_ = 0;
  // Arrival (`now`) of the newest odometry sample (0: none yet).
  Utime last_odometry_arrival_ = 0;
  LocalizerCounters counters_;
};

// The spread of a pose seen at a stamp off by a zero-mean error of `sigma_s` seconds while the
// robot moves with `velocity` (vx, vy, omega): sigma_s^2 * velocity * velocity^T.
Eigen::Matrix3d stampSpread(const Eigen::Vector3d& velocity, double sigma_s);

}  // namespace fieldline::fusion
