// The fusion process's bus side: ODOMETRY, VISION_LINES, FIELD_FEATURES, VISION_BALL,
// VISION_OBSTACLES (contact evidence) and TEAM_STATE (teammates' balls decide the twin) in;
// ROBOT_STATE on every odometry message (stamped with the odometry's utime) and again right after
// each line frame that corrected the pose (stamped with the newest odometry's utime: a repeated
// stamp, the corrected state), and BALL_STATE at a fixed rate out. The algorithms are the Localizer
// and the BallFilter; the node converts messages, reads time from its clock and reports refused
// inputs in SERVICE_STATUS (its metrics computed as SERVICE_STATUS goes out, not per message).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>

#include <fieldline/ball_state_t.hpp>
#include <fieldline/obstacle_observations_t.hpp>
#include <fieldline/robot_state_t.hpp>
#include <fieldline/team_state_t.hpp>

#include "common/bus/node.hpp"
#include "common/perception/field_features.hpp"
#include "common/perception/line_points.hpp"
#include "common/perception/obstacles.hpp"
#include "common/process/state_file.hpp"
#include "common/robot/robot_params.hpp"
#include "services/fusion/ball_filter.hpp"
#include "services/fusion/ball_tracker.hpp"
#include "services/fusion/localizer.hpp"
#include "services/fusion/team_twin.hpp"

namespace fieldline::fusion {

// The pose saved across restarts of the process (pose_memory.hpp).
struct PoseMemoryOptions {
  // The file; empty: no memory (every start is a start-up).
  std::string path;
  // Start without reading the file (a new match: the start-up prior holds); it is written still.
  bool fresh = false;
  // Written to the file and required of it: the field's name and who started the process
  // (pose_memory.hpp).
  std::string field;
  std::string supervisor;
  // Saves per second while the pose is TRACKING (and one when the node stops).
  double save_rate_hz = 5.0;
  // The machine's boot-time clock, us (a clock step does not move it); required with a path.
  std::function<Utime()> steady_now;
};

struct FusionNodeOptions {
  robot::RobotParams robot;
  LocalizerParams localizer;
  BallFilterParams ball;
  TeamBallVoteParams team_ball_vote;
  // BALL_STATE messages per second.
  double ball_rate_hz = 30.0;
  PoseMemoryOptions pose_memory;
};

// What fusion reads and writes (fieldline-fusion --print-io).
bus::ProcessIo fusionIo();

class FusionNode {
 public:
  // Subscribes on `node`'s primary bus; `matcher` is layer 2 (LineMatcher in the process).
  // With options.pose_memory.path: resumes from the saved pose when it may (resumeRefusal; a file
  // that cannot be read or parsed is an error "resume_corrupt", any other refusal a metric), and
  // saves the pose while TRACKING and when destroyed.
  FusionNode(bus::Node& node, FusionNodeOptions options, MatcherFunctions matcher);
  ~FusionNode();
  FusionNode(const FusionNode&) = delete;
  FusionNode& operator=(const FusionNode&) = delete;

  const Localizer& localizer() const { return localizer_; }
  std::int64_t robotStatesPublished() const { return robot_states_; }
  std::int64_t ballStatesPublished() const { return ball_states_; }

 private:
  void onOdometry(const odometry_t& m);
  // ROBOT_STATE: the estimate at time `t` (an odometry sample's), with its status.
  void publishState(Utime t);
  // publishState at the newest odometry time when a frame moved the estimate from `before`.
  void publishIfMoved(const perception::RobotEstimate& before);
  void onLines(const line_contours_t& m);
  void onFeatures(const field_features_t& m);
  void onBall(const ball_observation_t& m);
  void onObstacles(const obstacle_observations_t& m);
  void onTeam(const team_state_t& m);
  void publishBall();
  // The saved pose as the localizer's continuity reference, or why not (PoseMemoryOptions).
  void resumeFromSavedPose();
  // Writes the pose file when the reported status is TRACKING.
  void savePose();
  // Reports every refusal the localizer counted since the last call.
  void reportNewRejections();
  void updateMetrics();

  bus::Node& node_;
  FusionNodeOptions options_;
  Localizer localizer_;
  BallTracker ball_;
  TeamBallVoter twin_voter_;
  // Commits, resets and moves to the twin seen so far (TeamBallVoter::clearEvidence on a change).
  std::uint64_t pose_jumps_seen_ = 0;
  // utimes of the recent line frames (ascending): the corrections smoothedPose spreads back.
  std::deque<Utime> line_times_;
  perception::LinePoints lines_;
  perception::FieldFeatures features_;
  perception::ObstacleSightings obstacles_;
  std::map<std::string, std::uint64_t> reported_;
  robot_state_t state_msg_{};
  ball_state_t ball_msg_{};
  std::int64_t robot_states_ = 0;
  // ROBOT_STATEs of a tracked pose reported ODOMETRY_ONLY for their uncertainty
  // (LocalizerParams::tracking_max_sigma_m).
  std::int64_t uncertain_states_ = 0;
  std::int64_t ball_states_ = 0;
  // The pose file's writer (PoseMemoryOptions::path); none without a path.
  std::optional<process::StateFileWriter> pose_file_;
};

}  // namespace fieldline::fusion
