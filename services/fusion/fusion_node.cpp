#include "services/fusion/fusion_node.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "common/msg/estimates.hpp"
#include "common/msg/field_features.hpp"
#include "common/msg/line_contours.hpp"
#include "common/msg/obstacle_observations.hpp"
#include "common/msg/team_state.hpp"
#include "services/fusion/pose_memory.hpp"

namespace fieldline::fusion {
namespace {

// Refusals that mean bad input (counted as errors); the rest (a poor match, a gated
// measurement) are the filter doing its job and show as metrics.
bool isBadInput(const std::string& reason) {
  for (const char* kind :
       {"from_future", "too_old", "not_finite", "not_positive_definite", "duplicate",
        "odometry_jump", "odometry_out_of_order", "absurd", "wheel_count"}) {
    if (reason.find(kind) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

FusionNode::FusionNode(bus::Node& node, FusionNodeOptions options, MatcherFunctions matcher)
    : node_(node),
      options_(std::move(options)),
      localizer_(options_.robot, options_.localizer, std::move(matcher)),
      ball_(options_.ball),
      twin_voter_(node.robotId(), options_.team_ball_vote) {
  if (!(options_.ball_rate_hz > 0.0 && options_.ball_rate_hz <= 1000.0)) {
    throw std::invalid_argument("fusion: ball_rate_hz must be in (0, 1000]");
  }
  node_.subscribe(bus::channels::kOdometry, [this](const odometry_t& m) { onOdometry(m); });
  // The filter runs on odometry at 50 Hz: without it (bridge dead, serial unplugged) the frames
  // are fused on the held velocity and SERVICE_STATUS says WARN "ODOMETRY silent".
  node_.requireInput(bus::channels::kOdometry, 25.0);
  node_.subscribe(bus::channels::kVisionLines, [this](const line_contours_t& m) { onLines(m); });
  // Without lines the pose is dead reckoning (ODOMETRY_ONLY): WARN "VISION_LINES silent" (issue
  // 34, red-team finding 5: fusion said ok with the camera stopped for 20 s).
  node_.requireInput(
      bus::channels::kVisionLines,
      bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kVisionLines.name));
  node_.subscribe(bus::channels::kFieldFeatures,
                  [this](const field_features_t& m) { onFeatures(m); });
  // VISION_BALL, VISION_OBSTACLES and TEAM_STATE wake the loop too. Read deferred
  // (bus::Node::subscribeDeferred; tried) they saved no wake-up, since a frame's ball and
  // obstacles arrive with its lines, and every wake-up paid an empty read of the deferred socket
  // (docs/performance.md, "Fusion").
  node_.subscribe(bus::channels::kVisionBall, [this](const ball_observation_t& m) { onBall(m); });
  node_.subscribe(bus::channels::kVisionObstacles,
                  [this](const obstacle_observations_t& m) { onObstacles(m); });
  // Optional: a robot without teamcomm (or alone) keeps continuity and the start prior.
  node_.subscribe(bus::channels::kTeamState, [this](const team_state_t& m) { onTeam(m); });
  node_.every(static_cast<Utime>(std::llround(1e6 / options_.ball_rate_hz)),
              [this] { publishBall(); });
  node_.declareIo(fusionIo());
  // The metrics as SERVICE_STATUS goes out (once a second), not after every message.
  node_.beforeStatus([this] { updateMetrics(); });
  const PoseMemoryOptions& memory = options_.pose_memory;
  if (!memory.path.empty()) {
    if (!memory.steady_now || !(memory.save_rate_hz > 0.0 && memory.save_rate_hz <= 100.0)) {
      throw std::invalid_argument(
          "fusion: a pose memory needs a steady clock and a save rate in (0, 100] Hz");
    }
    pose_file_.emplace(memory.path);
    node_.setMetric("resumed", 0.0);
    if (options_.localizer.resume_max_age_s <= 0.0) {
      spdlog::info("the saved pose in {} is not read (localizer.resume_max_age_s 0)", memory.path);
    } else if (memory.fresh) {
      spdlog::info("starting fresh (--fresh): the saved pose in {} is not read", memory.path);
    } else {
      resumeFromSavedPose();
    }
    node_.every(static_cast<Utime>(std::llround(1e6 / memory.save_rate_hz)),
                [this] { savePose(); });
  }
}

FusionNode::~FusionNode() {
  // A clean stop (SIGTERM: systemctl restart, the launcher) leaves the newest pose.
  if (!options_.pose_memory.path.empty()) savePose();
}

void FusionNode::resumeFromSavedPose() {
  const PoseMemoryOptions& memory = options_.pose_memory;
  std::optional<SavedPose> saved;
  try {
    saved = readSavedPoseFile(memory.path);
  } catch (const std::runtime_error& e) {
    node_.reportError("resume_corrupt",
                      std::string("saved pose refused, starting up: ") + e.what());
    return;
  }
  if (!saved) {
    spdlog::info("no saved pose in {}: a start-up (the own-half prior decides the twin)",
                 memory.path);
    return;
  }
  double age_s = 0.0;
  const std::string refusal =
      resumeRefusal(*saved, node_.robotId(), memory.field, memory.supervisor, memory.steady_now(),
                    options_.localizer.resume_max_age_s, age_s);
  if (!refusal.empty()) {
    spdlog::info(
        "saved pose in {} refused ({}: robot {}, field {}, supervisor '{}', {:.1f} s old; "
        "resumed within {:.1f} s): a start-up",
        memory.path, refusal, saved->robot_id, saved->field, saved->supervisor, age_s,
        options_.localizer.resume_max_age_s);
    node_.setMetric(refusal, 1.0);
    return;
  }
  const Utime saved_utime = node_.now() - static_cast<Utime>(std::llround(age_s * 1e6));
  localizer_.resumeFrom(saved->pose, saved->covariance, saved_utime, saved->twin_ambiguous);
  spdlog::info(
      "resumed from the pose saved in {} {:.2f} s ago: ({:.2f}, {:.2f}, {:.2f} rad){}, the twin's "
      "reference of the first commit",
      memory.path, age_s, saved->pose.x, saved->pose.y, saved->pose.phi,
      saved->twin_ambiguous ? ", saved twin-ambiguous (the start-up prior)" : "");
  node_.setMetric("resumed", 1.0);
  node_.setMetric("resumed_age_s", age_s);
  node_.setMetric("resumed_x", saved->pose.x);
  node_.setMetric("resumed_y", saved->pose.y);
}

void FusionNode::savePose() {
  const perception::RobotEstimate e = localizer_.estimate(node_.now());
  if (e.status != perception::LocalizationStatus::kTracking) return;
  const PoseMemoryOptions& memory = options_.pose_memory;
  SavedPose saved;
  saved.robot_id = node_.robotId();
  saved.field = memory.field;
  saved.supervisor = memory.supervisor;
  saved.saved_steady_us = memory.steady_now();
  saved.pose = e.pose;
  saved.covariance = e.covariance;
  saved.twin_ambiguous = e.twin_ambiguous;
  try {
    pose_file_->write(encodeSavedPose(saved));
  } catch (const std::runtime_error& error) {
    node_.reportError("state_file", error.what());
  }
}

bus::ProcessIo fusionIo() {
  return bus::ProcessIo("fusion")
      .reads(bus::channels::kOdometry)
      .reads(bus::channels::kVisionLines)
      .readsIfPresent(bus::channels::kFieldFeatures)
      .readsIfPresent(bus::channels::kVisionBall)
      .readsIfPresent(bus::channels::kVisionObstacles)
      .readsIfPresent(bus::channels::kTeamState)
      .writes(bus::channels::kRobotState)
      .writes(bus::channels::kBallState);
}

void FusionNode::onOdometry(const odometry_t& m) {
  OdometrySample sample;
  sample.utime = m.header.utime;
  // The bus checked wheel_count (0, 3 or 4) and the arrays' sizes; the odometry layer checks
  // that the count is the robot file's.
  sample.ticks.assign(m.ticks.begin(), m.ticks.end());
  sample.movement = {m.dx, m.dy, m.dphi};
  sample.resync = (m.status & odometry_t::STATUS_RESYNC) != 0;
  sample.controller_utime = m.controller_utime;
  sample.has_currents = (m.status & odometry_t::STATUS_CURRENTS) != 0;
  if (sample.has_currents)
    sample.wheel_current.assign(m.wheel_current.begin(), m.wheel_current.end());
  sample.has_gyro = (m.status & odometry_t::STATUS_GYRO) != 0;
  sample.gyro_dphi = m.gyro_dphi;
  localizer_.addOdometry(sample, node_.now());

  // The estimate at this odometry's physical time, whatever happened to the sample: its
  // header.utime, the bridge's stamp from the controller's clock (without the serial link's
  // jitter).
  publishState(m.header.utime);
  reportNewRejections();
}

void FusionNode::publishState(Utime t) {
  perception::RobotEstimate e = localizer_.estimate(node_.now());
  if (const auto s = localizer_.stateAt(t)) {
    e.pose = s->pose();
    const Eigen::Vector3d v = s->groundVelocity();
    e.vx = v.x();
    e.vy = v.y();
    e.omega = v.z();
    e.covariance = localizer_.reportedCovariance(*s);
    e.status = localizer_.reportedStatus(e.covariance, node_.now());
  }
  e.utime = t;
  msg::toMessage(e, state_msg_);
  if (node_.publish(bus::channels::kRobotState, state_msg_)) ++robot_states_;
  if (e.status != perception::LocalizationStatus::kTracking &&
      localizer_.reportedStatus(Eigen::Matrix3d::Zero(), node_.now()) ==
          perception::LocalizationStatus::kTracking)
    ++uncertain_states_;
}

void FusionNode::publishIfMoved(const perception::RobotEstimate& before) {
  // A frame that corrected the pose (or moved it: a commit, a reset, a new status) goes out at
  // once, as the state at the newest odometry sample (the same stamp as the last ROBOT_STATE,
  // corrected), instead of waiting up to an odometry period for the next sample (image-to-pose
  // latency, docs/fusion.md). A frame that waits for its odometry is corrected, and published,
  // with that sample.
  const perception::RobotEstimate after = localizer_.estimate(node_.now());
  const auto frame_of = [](const perception::RobotEstimate& e) {
    return e.since_vision_us > 0 ? e.utime - e.since_vision_us : 0;
  };
  if (after.utime > 0 && (frame_of(after) != frame_of(before) || after.status != before.status ||
                          after.pose.x != before.pose.x || after.pose.y != before.pose.y ||
                          after.pose.phi != before.pose.phi)) {
    publishState(after.utime);
  }
}

void FusionNode::onLines(const line_contours_t& m) {
  msg::fromMessage(m, lines_);
  const perception::RobotEstimate before = localizer_.estimate(node_.now());
  localizer_.addLines(lines_.points, m.header.utime, node_.now());
  publishIfMoved(before);
  const auto at = std::upper_bound(line_times_.begin(), line_times_.end(), m.header.utime);
  if (at == line_times_.begin() || *std::prev(at) != m.header.utime)
    line_times_.insert(at, m.header.utime);
  reportNewRejections();
}

void FusionNode::onFeatures(const field_features_t& m) {
  msg::fromMessage(m, features_);
  const perception::RobotEstimate before = localizer_.estimate(node_.now());
  localizer_.addFeatures(features_, m.header.utime, node_.now());
  publishIfMoved(before);
  reportNewRejections();
}

void FusionNode::onObstacles(const obstacle_observations_t& m) {
  msg::fromMessage(m, obstacles_);
  localizer_.addObstacles(obstacles_, node_.now());
  reportNewRejections();
}

void FusionNode::onTeam(const team_state_t& m) {
  twin_voter_.setTeam(msg::fromMessage(m));
  for (const auto& [kind, n] : twin_voter_.refusals()) {
    std::uint64_t& seen = reported_[kind];
    for (; seen < n; ++seen)
      node_.reportError(kind, "TEAM_STATE entry refused: " + kind);
  }
}

void FusionNode::onBall(const ball_observation_t& m) {
  const perception::BallSighting sighting = msg::fromMessage(m);
  const BallRejection r = ball_.add(sighting);
  if (r == BallRejection::kNone) {
    // Our ball where our pose at its time puts it, against the teammates' balls.
    if (!sighting.visible) return;
    if (const auto s = localizer_.stateAt(sighting.utime)) {
      const geometry::Vec2 ours = geometry::pointRobotToField(s->pose(), {sighting.x, sighting.y});
      // Agreements judged with a pose that has since jumped (a commit, a reset, a move to the
      // twin) say nothing about the new one.
      const LocalizerCounters& c = localizer_.counters();
      const auto jumps = [&c] { return c.commits + c.resets + c.twin_flips_by_team; };
      if (jumps() != pose_jumps_seen_) {
        twin_voter_.clearEvidence();
        pose_jumps_seen_ = jumps();
      }
      const std::uint64_t flips = c.twin_flips_by_team;
      const double sigma = std::max(sighting.sigma_radial, sighting.sigma_tangential);
      localizer_.addTwinVote(twin_voter_.vote(ours, sigma, sighting.utime, !localizer_.ambiguous()),
                             sighting.utime);
      if (c.twin_flips_by_team != flips) ball_.mirrorThroughCentre();
    }
    return;
  }
  const std::string kind = toString(r);
  node_.reportError(kind, "VISION_BALL refused: " + kind);
}

void FusionNode::publishBall() {
  const Utime now = node_.now();
  // Line frames older than the window cannot correct a pose any more.
  const Utime keep_from = now - static_cast<Utime>(2e6);
  while (!line_times_.empty() && line_times_.front() < keep_from)
    line_times_.pop_front();
  const PoseAt filtered = [this](Utime t) { return localizer_.stateAt(t); };
  const PoseAt pose_at =
      options_.ball.smooth_pose
          ? PoseAt([this, &filtered](Utime t) { return smoothedPose(filtered, line_times_, t); })
          : filtered;
  const perception::BallEstimate e = ball_.estimate(now, pose_at);
  msg::toMessage(e, ball_msg_);
  if (node_.publish(bus::channels::kBallState, ball_msg_)) ++ball_states_;
}

void FusionNode::reportNewRejections() {
  for (const auto& [reason, n] : localizer_.counters().rejected) {
    std::uint64_t& seen = reported_[reason];
    if (n == seen) continue;
    if (isBadInput(reason)) {
      for (std::uint64_t i = seen; i < n; ++i)
        node_.reportError(reason, "input refused: " + reason);
    } else {
      node_.setMetric(reason + "_count", static_cast<double>(n));
    }
    seen = n;
  }
}

void FusionNode::updateMetrics() {
  node_.setMetric("localization_status",
                  static_cast<double>(localizer_.estimate(node_.now()).status));
  node_.setMetric("correction_cm", 100.0 * localizer_.lastCorrectionM());
  node_.setMetric("states_too_uncertain", static_cast<double>(uncertain_states_));
  node_.setMetric("correction_deg", localizer_.lastCorrectionRad() * 180.0 / 3.141592653589793);
  node_.setMetric("match_cost_cm", 100.0 * std::max(0.0, localizer_.lastCost()));
  node_.setMetric("ambiguous", localizer_.ambiguous() ? 1.0 : 0.0);
  node_.setMetric("hypotheses", static_cast<double>(localizer_.hypothesisCount()));
  node_.setMetric("lost_count", static_cast<double>(localizer_.counters().lost));
  node_.setMetric("ambiguous_commits",
                  static_cast<double>(localizer_.counters().ambiguous_commits));
  node_.setMetric("twin_resets_refused",
                  static_cast<double>(localizer_.counters().twin_resets_refused));
  node_.setMetric("twin_confirmed_by_team",
                  static_cast<double>(localizer_.counters().twin_confirmed_by_team));
  node_.setMetric("twin_flips_by_team",
                  static_cast<double>(localizer_.counters().twin_flips_by_team));
  node_.setMetric("twin_doubted_by_team",
                  static_cast<double>(localizer_.counters().twin_doubted_by_team));
  node_.setMetric("frames_waited_for_odometry",
                  static_cast<double>(localizer_.counters().frames_waited));
  node_.setMetric("odometry_silent", localizer_.odometrySilent(node_.now()) ? 1.0 : 0.0);
  node_.setMetric("replays", static_cast<double>(localizer_.filter().replays()));
  node_.setMetric("gate_resets", static_cast<double>(localizer_.counters().resets));
  node_.setMetric("slips", static_cast<double>(localizer_.counters().slips));
  node_.setMetric("pinned_slips", static_cast<double>(localizer_.counters().pinned_slips));
  node_.setMetric("contact_slips", static_cast<double>(localizer_.counters().contact_slips));
  node_.setMetric("contact_frames", static_cast<double>(localizer_.counters().contact_frames));
  node_.setMetric("current_contacts", static_cast<double>(localizer_.counters().current_contacts));
  node_.setMetric("gyro_steps", static_cast<double>(localizer_.counters().gyro_steps));
  node_.setMetric("gyro_bias_deg_s", localizer_.gyroBias() * 180.0 / std::numbers::pi);
  node_.setMetric("twist_searches", static_cast<double>(localizer_.counters().twist_searches));
  node_.setMetric("headings_weighted_down",
                  static_cast<double>(localizer_.counters().headings_weighted_down));
  node_.setMetric("headings_confirmed",
                  static_cast<double>(localizer_.counters().headings_confirmed));
  node_.setMetric("ball_restarts_far", static_cast<double>(ball_.committed().restartsFar()));
  node_.setMetric("ball_unseen_invalidations",
                  static_cast<double>(ball_.committed().unseenInvalidations()));
  node_.setMetric("ball_restarts_with_velocity",
                  static_cast<double>(ball_.committed().restartsWithVelocity()));
  node_.setMetric("ball_too_fast_restarts",
                  static_cast<double>(ball_.committed().tooFastRestarts()));
  for (const auto& [kind, n] : ball_.refusals())
    node_.setMetric(kind + "_count", static_cast<double>(n));
}

}  // namespace fieldline::fusion
