#include "services/fusion/fusion_config.hpp"

#include <cmath>
#include <string>

namespace fieldline::fusion {
namespace {

Utime micros(double seconds) {
  return static_cast<Utime>(std::llround(seconds * 1e6));
}
double seconds(Utime us) {
  return static_cast<double>(us) * 1e-6;
}

void loadFilter(const config::Node& n, FilterParams& p) {
  p.window_us = micros(n.getOr<double>("window_s", seconds(p.window_us), 0.1, 10.0));
  p.future_tolerance_us =
      micros(n.getOr<double>("future_tolerance_s", seconds(p.future_tolerance_us), 0.0, 1.0));
  p.gate2 = n.getOr<double>("gate_chi2", p.gate2, 0.0, 1e6);
  n.rejectUnknownKeys();
}

void loadProcessNoise(const config::Node& n, ProcessNoise& p) {
  p.linear_acceleration = n.getOr<double>("linear_acceleration", p.linear_acceleration, 0.0, 100.0);
  p.angular_acceleration =
      n.getOr<double>("angular_acceleration", p.angular_acceleration, 0.0, 1000.0);
  p.position_density = n.getOr<double>("position_density", p.position_density, 0.0, 10.0);
  p.heading_density = n.getOr<double>("heading_density", p.heading_density, 0.0, 10.0);
  p.odometry_velocity_sigma =
      n.getOr<double>("odometry_velocity_sigma", p.odometry_velocity_sigma, 0.0, 10.0);
  p.odometry_omega_sigma =
      n.getOr<double>("odometry_omega_sigma", p.odometry_omega_sigma, 0.0, 10.0);
  n.rejectUnknownKeys();
}

void loadOdometry(const config::Node& n, OdometryNoise& p) {
  p.wheel_relative_sigma =
      n.getOr<double>("wheel_relative_sigma", p.wheel_relative_sigma, 0.0, 1.0);
  p.wheel_slip_density = n.getOr<double>("wheel_slip_density", p.wheel_slip_density, 0.0, 1.0);
  p.rotation_slip_density =
      n.getOr<double>("rotation_slip_density", p.rotation_slip_density, 0.0, 10.0);
  p.translation_sigma_per_m =
      n.getOr<double>("translation_sigma_per_m", p.translation_sigma_per_m, 0.0, 1.0);
  p.rotation_sigma_per_rad =
      n.getOr<double>("rotation_sigma_per_rad", p.rotation_sigma_per_rad, 0.0, 1.0);
  p.rotation_sigma_per_m =
      n.getOr<double>("rotation_sigma_per_m", p.rotation_sigma_per_m, 0.0, 1.0);
  p.max_interval_s = n.getOr<double>("max_interval_s", p.max_interval_s, 0.005, 10.0);
  p.max_speed_factor = n.getOr<double>("max_speed_factor", p.max_speed_factor, 1.0, 100.0);
  p.use_gyro = n.getOr<bool>("use_gyro", p.use_gyro);
  p.gyro_max_rate = n.getOr<double>("gyro_max_rate", p.gyro_max_rate, 0.0, 1000.0);
  p.gyro_heading_density =
      n.getOr<double>("gyro_heading_density", p.gyro_heading_density, 0.0, 10.0);
  n.rejectUnknownKeys();
}

void loadLocalizer(const config::Node& n, LocalizerParams& p) {
  p.accept_cost_m = n.getOr<double>("accept_cost_m", p.accept_cost_m, 0.001, 1.0);
  p.lost_cost_m = n.getOr<double>("lost_cost_m", p.lost_cost_m, 0.001, 1.0);
  p.lost_frames = n.getOr<int>("lost_frames", p.lost_frames, 1, 1000);
  p.contradict_min_points = static_cast<std::size_t>(
      n.getOr<int>("contradict_min_points", static_cast<int>(p.contradict_min_points), 1, 100000));
  p.gated_frames_reset = n.getOr<int>("gated_frames_reset", p.gated_frames_reset, 1, 1000);
  p.slip_confirm_m = n.getOr<double>("slip_confirm_m", p.slip_confirm_m, 0.0, 10.0);
  p.slip_confirm_rad = n.getOr<double>("slip_confirm_rad", p.slip_confirm_rad, 0.0, 3.2);
  p.slip_single_frame_rad =
      n.getOr<double>("slip_single_frame_rad", p.slip_single_frame_rad, 0.0, 3.2);
  p.slip_pinned_ratio = n.getOr<double>("slip_pinned_ratio", p.slip_pinned_ratio, 0.0, 100.0);
  p.slip_pinned_chi2 = n.getOr<double>("slip_pinned_chi2", p.slip_pinned_chi2, 0.0, 1e6);
  p.commit_frames = n.getOr<int>("commit_frames", p.commit_frames, 1, 100);
  p.commit_margin_m = n.getOr<double>("commit_margin_m", p.commit_margin_m, 0.0, 1.0);
  p.trust_frames = n.getOr<int>("trust_frames", p.trust_frames, 0, 1000);
  p.twin_margin_m = n.getOr<double>("twin_margin_m", p.twin_margin_m, 0.0, 30.0);
  p.twin_margin_sigmas = n.getOr<double>("twin_margin_sigmas", p.twin_margin_sigmas, 0.0, 100.0);
  p.max_waiting_frames = static_cast<std::size_t>(
      n.getOr<int>("max_waiting_frames", static_cast<int>(p.max_waiting_frames), 1, 1000));
  p.max_wait_us = micros(n.getOr<double>("max_wait_s", seconds(p.max_wait_us), 0.05, 5.0));
  p.feature_gate_m = n.getOr<double>("feature_gate_m", p.feature_gate_m, 0.0, 20.0);
  p.feature_gate_rad = n.getOr<double>("feature_gate_rad", p.feature_gate_rad, 0.0, 4.0);
  p.contradict_m = n.getOr<double>("contradict_m", p.contradict_m, 0.0, 30.0);
  p.vision_timeout_us =
      micros(n.getOr<double>("vision_timeout_s", seconds(p.vision_timeout_us), 0.05, 60.0));
  p.tracking_max_sigma_m =
      n.getOr<double>("tracking_max_sigma_m", p.tracking_max_sigma_m, 0.0, 10.0);
  p.reset_confirm_frames = n.getOr<int>("reset_confirm_frames", p.reset_confirm_frames, 0, 100);
  p.search_step_m = n.getOr<double>("search_step_m", p.search_step_m, 0.05, 5.0);
  p.search_headings = n.getOr<int>("search_headings", p.search_headings, 4, 360);
  p.search_points = n.getOr<int>("search_points", p.search_points, 5, 10000);
  p.max_hypotheses = static_cast<std::size_t>(
      n.getOr<int>("max_hypotheses", static_cast<int>(p.max_hypotheses), 1, 1000));
  p.local_search_s = n.getOr<double>("local_search_s", p.local_search_s, 0.0, 10.0);
  p.local_search_step_rad =
      n.getOr<double>("local_search_step_rad", p.local_search_step_rad, 0.01, 3.2);
  p.local_search_steps = n.getOr<int>("local_search_steps", p.local_search_steps, 0, 100);
  if (n.has("start_prior")) {
    p.start_prior = n.getChoice("start_prior", {"own_half", "none"}) == "own_half"
                        ? StartPrior::kOwnHalf
                        : StartPrior::kNone;
  }
  n.rejectUnknownKeys();
  if (p.lost_cost_m < p.accept_cost_m) {
    n.fail("lost_cost_m", "must be at least accept_cost_m");
  }
  // A hypothesis close enough to be fused must not also count as contradicting the estimate.
  if (p.contradict_m < p.feature_gate_m) {
    n.fail(n.has("contradict_m") ? "contradict_m" : "feature_gate_m",
           "contradict_m must be at least feature_gate_m");
  }
}

void loadCalibration(const config::Node& n, LocalizerParams& p) {
  p.correction_floor_m = n.getOr<double>("correction_floor_m", p.correction_floor_m, 0.0, 5.0);
  p.correction_floor_rad =
      n.getOr<double>("correction_floor_rad", p.correction_floor_rad, 0.0, 3.0);
  p.correction_inflation =
      n.getOr<double>("correction_inflation", p.correction_inflation, 0.01, 1e4);
  p.correction_cost_gain =
      n.getOr<double>("correction_cost_gain", p.correction_cost_gain, 0.0, 1e3);
  p.correction_cost_gain_rad =
      n.getOr<double>("correction_cost_gain_rad", p.correction_cost_gain_rad, 0.0, 1e3);
  p.commit_sigma_m = n.getOr<double>("commit_sigma_m", p.commit_sigma_m, 0.0, 10.0);
  p.commit_sigma_rad = n.getOr<double>("commit_sigma_rad", p.commit_sigma_rad, 0.0, 3.2);
  p.state_floor_m = n.getOr<double>("state_floor_m", p.state_floor_m, 0.0, 5.0);
  p.state_floor_rad = n.getOr<double>("state_floor_rad", p.state_floor_rad, 0.0, 3.2);
  p.stamp_sigma_s = n.getOr<double>("stamp_sigma_s", p.stamp_sigma_s, 0.0, 1.0);
  p.correction_stamp_sigma_s =
      n.getOr<double>("correction_stamp_sigma_s", p.correction_stamp_sigma_s, 0.0, 1.0);
  SlipModel& slip = p.filter.slip;
  slip.max_m = n.getOr<double>("slip_max_m", slip.max_m, 0.0, 10.0);
  slip.max_rad = n.getOr<double>("slip_max_rad", slip.max_rad, 0.0, 3.2);
  slip.max_rad_gyro = n.getOr<double>("slip_max_rad_gyro", slip.max_rad_gyro, 0.0, 3.2);
  slip.max_speed = n.getOr<double>("slip_max_speed", slip.max_speed, 0.0, 100.0);
  slip.base_m = n.getOr<double>("slip_base_m", slip.base_m, 0.0, 10.0);
  slip.inflation = n.getOr<double>("slip_inflation", slip.inflation, 0.0, 100.0);
  slip.gyro_heading_chi2 = n.getOr<double>("gyro_heading_chi2", slip.gyro_heading_chi2, 0.0, 1e6);
  // The Huber bound must lie inside the gate: at or beyond it, every weighted-down heading would
  // have been refused by the gate first.
  if (slip.gyro_heading_chi2 > 0.0 && p.filter.gate2 > 0.0 &&
      slip.gyro_heading_chi2 >= p.filter.gate2) {
    n.fail("gyro_heading_chi2",
           "must be below filter.gate_chi2 (" + std::to_string(p.filter.gate2) + "), or 0 (off)");
  }
  p.heading_confirm_rad = n.getOr<double>("heading_confirm_rad", p.heading_confirm_rad, 0.0, 3.2);
  n.rejectUnknownKeys();
}

void loadContact(const config::Node& n, LocalizerParams& l) {
  ContactModel& p = l.filter.contact;
  l.contact_search_steps = n.getOr<int>("search_steps", l.contact_search_steps, 0, 20);
  l.twist_search_always = n.getOr<bool>("search_always", l.twist_search_always);
  l.twist_search_with_gyro = n.getOr<bool>("search_with_gyro", l.twist_search_with_gyro);
  l.contact_search_min_points = static_cast<std::size_t>(
      n.getOr<int>("search_min_points", static_cast<int>(l.contact_search_min_points), 1, 100000));
  p.distance_m = n.getOr<double>("distance_m", p.distance_m, 0.0, 5.0);
  p.hold_us = micros(n.getOr<double>("hold_s", seconds(p.hold_us), 0.0, 5.0));
  p.position_density = n.getOr<double>("position_density", p.position_density, 0.0, 10.0);
  p.heading_density = n.getOr<double>("heading_density", p.heading_density, 0.0, 10.0);
  p.gyro_heading_density =
      n.getOr<double>("gyro_heading_density", p.gyro_heading_density, 0.0, 10.0);
  PushModel& push = l.filter.push;
  push.density = n.getOr<double>("push_density", push.density, 0.0, 100.0);
  push.contact_decay_s =
      n.getOr<double>("push_contact_decay_s", push.contact_decay_s, 0.001, 100.0);
  push.free_decay_s = n.getOr<double>("push_free_decay_s", push.free_decay_s, 0.001, 100.0);
  push.max_speed = n.getOr<double>("push_max_speed", push.max_speed, 0.0, 100.0);
  push.unconfirmed_us =
      micros(n.getOr<double>("push_unconfirmed_s", seconds(push.unconfirmed_us), 0.0, 10.0));
  CurrentContactParams& c = l.current_contact;
  c.force_threshold_n = n.getOr<double>("current_force_n", c.force_threshold_n, 0.0, 1e4);
  c.samples = n.getOr<int>("current_samples", c.samples, 1, 100);
  c.max_current_a = n.getOr<double>("current_max_a", c.max_current_a, 0.1, 1e4);
  n.rejectUnknownKeys();
}

void loadBall(const config::Node& n, FusionConfig& c) {
  BallFilterParams& p = c.ball;
  p.rolling_deceleration =
      n.getOr<double>("rolling_deceleration", p.rolling_deceleration, 0.0, 20.0);
  p.acceleration_density =
      n.getOr<double>("acceleration_density", p.acceleration_density, 0.0, 1000.0);
  p.max_age_s = n.getOr<double>("max_age_s", p.max_age_s, 0.05, 60.0);
  p.gate2 = n.getOr<double>("gate_chi2", p.gate2, 0.1, 1e6);
  p.restart_after_outliers =
      n.getOr<int>("restart_after_outliers", p.restart_after_outliers, 1, 1000);
  p.max_range_m = n.getOr<double>("max_range_m", p.max_range_m, 0.1, 50.0);
  p.sighting_floor_m = n.getOr<double>("sighting_floor_m", p.sighting_floor_m, 0.0, 5.0);
  p.invalid_after_outlier = n.getOr<bool>("invalid_after_outlier", p.invalid_after_outlier);
  p.unseen_range_m = n.getOr<double>("unseen_range_m", p.unseen_range_m, 0.0, 20.0);
  p.unseen_frames = n.getOr<int>("unseen_frames", p.unseen_frames, 1, 1000);
  p.restart_distance_m = n.getOr<double>("restart_distance_m", p.restart_distance_m, 0.0, 50.0);
  p.restart_max_sigma_m =
      n.getOr<double>("restart_max_sigma_m", p.restart_max_sigma_m, 0.001, 10.0);
  p.pose_max_unconfirmed_s =
      n.getOr<double>("pose_max_unconfirmed_s", p.pose_max_unconfirmed_s, 0.0, 10.0);
  p.pose_max_correction_rad =
      n.getOr<double>("pose_max_correction_rad", p.pose_max_correction_rad, 0.0, 4.0);
  p.velocity_from_pair = n.getOr<bool>("velocity_from_pair", p.velocity_from_pair);
  p.pair_max_age_s = n.getOr<double>("pair_max_age_s", p.pair_max_age_s, 0.001, 5.0);
  p.fit_min_sightings = n.getOr<int>("fit_min_sightings", p.fit_min_sightings, 2, 100);
  p.pair_max_speed = n.getOr<double>("pair_max_speed", p.pair_max_speed, 0.1, 100.0);
  p.restart_speed_sigma =
      n.getOr<double>("restart_speed_sigma", p.restart_speed_sigma, 0.01, 100.0);
  p.settle_s = n.getOr<double>("settle_s", p.settle_s, 0.0, 1.0);
  p.smooth_pose = n.getOr<bool>("smooth_pose", p.smooth_pose);
  c.ball_rate_hz = n.getOr<double>("rate_hz", c.ball_rate_hz, 1.0, 200.0);
  n.rejectUnknownKeys();
}

void loadTwinByTeam(const config::Node& n, FusionConfig& c) {
  TeamBallVoteParams& p = c.team_ball_vote;
  c.localizer.twin_vote_run = n.getOr<int>("votes", c.localizer.twin_vote_run, 0, 1000);
  c.localizer.twin_vote_gap_us =
      micros(n.getOr<double>("vote_gap_s", seconds(c.localizer.twin_vote_gap_us), 0.1, 60.0));
  p.agree_m = n.getOr<double>("agree_m", p.agree_m, 0.01, 5.0);
  p.min_centre_distance_m =
      n.getOr<double>("min_centre_distance_m", p.min_centre_distance_m, 0.02, 10.0);
  if (p.min_centre_distance_m <= p.agree_m) {
    n.fail("min_centre_distance_m",
           "must be larger than agree_m (else one teammate's ball agrees "
           "with both our ball and its mirror image)");
  }
  p.max_sighting_sigma_m =
      n.getOr<double>("max_sighting_sigma_m", p.max_sighting_sigma_m, 0.001, 10.0);
  p.min_teammates = n.getOr<int>("min_teammates", p.min_teammates, 1, 5);
  p.max_ball_age_us =
      micros(n.getOr<double>("max_ball_age_s", seconds(p.max_ball_age_us), 0.0, 5.0));
  p.max_picture_gap_us =
      micros(n.getOr<double>("max_picture_gap_s", seconds(p.max_picture_gap_us), 0.0, 5.0));
  p.evidence_window_us =
      micros(n.getOr<double>("evidence_window_s", seconds(p.evidence_window_us), 0.0, 30.0));
  n.rejectUnknownKeys();
}

}  // namespace

FusionConfig loadFusionConfig(const config::Node& root) {
  FusionConfig c;
  if (const auto n = root.childIf("filter")) loadFilter(*n, c.localizer.filter);
  if (const auto n = root.childIf("process_noise")) loadProcessNoise(*n, c.localizer.filter.noise);
  if (const auto n = root.childIf("odometry")) loadOdometry(*n, c.localizer.odometry);
  if (const auto n = root.childIf("localizer")) loadLocalizer(*n, c.localizer);
  if (const auto n = root.childIf("calibration")) loadCalibration(*n, c.localizer);
  if (const auto n = root.childIf("contact")) loadContact(*n, c.localizer);
  if (const auto n = root.childIf("ball")) loadBall(*n, c);
  if (const auto n = root.childIf("twin_by_team")) loadTwinByTeam(*n, c);
  if (const auto n = root.childIf("matcher")) c.matcher = loadMatcherParams(*n);
  root.rejectUnknownKeys();
  return c;
}

FusionConfig loadFusionConfigPreset(const std::string& name_or_path) {
  return loadFusionConfig(config::Node::loadFile(config::resolvePreset("fusion", name_or_path)));
}

}  // namespace fieldline::fusion
