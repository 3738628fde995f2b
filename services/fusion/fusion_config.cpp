// Every fusion setting, declared once (common/config/settings.hpp): key, range, unit, why. The
// defaults are the structs' initializers; config/fusion/default.yaml is `fieldline-fusion
// --print-config` of them, and docs/settings/fusion.md the table (both checked by
// tests/unit/fusion/fusion_config_test.cpp).
#include "services/fusion/fusion_config.hpp"

#include <optional>
#include <string>

namespace fieldline::fusion {
namespace {

using config::SettingsTable;
using FC = FusionConfig;
using LP = LocalizerParams;
using FP = FilterParams;

void declareFilter(SettingsTable<FC>& t) {
  t.section("filter", "The delay-aware filter (seed 4.7).");
  t.addSeconds("filter.window_s", 0.1, 10.0,
               "How far back a late measurement may reach (a camera frame arrives 60-100 ms late)",
               &FC::localizer, &LP::filter, &FP::window_us);
  t.addSeconds("filter.future_tolerance_s", 0.0, 1.0,
               "A measurement stamped later than now plus this is from the future and refused",
               &FC::localizer, &LP::filter, &FP::future_tolerance_us);
  t.add("filter.gate_chi2", 0.0, 1e6, "1",
        "Squared Mahalanobis distance beyond which a pose measurement is refused (chi^2, 3 dof, "
        "99.9 %); 0: no gate",
        &FC::localizer, &LP::filter, &FP::gate2);

  t.section("process_noise", "What the filter does not see between samples (seed 4.6).");
  const auto noise = [&](const char* key, double max, const char* unit, const char* why,
                         double ProcessNoise::*m) {
    t.add(std::string("process_noise.") + key, 0.0, max, unit, why, &FC::localizer, &LP::filter,
          &FP::noise, m);
  };
  noise("linear_acceleration", 100.0, "m/s^2/sqrt(Hz)",
        "Unseen linear acceleration, white-noise density", &ProcessNoise::linear_acceleration);
  noise("angular_acceleration", 1000.0, "rad/s^2/sqrt(Hz)",
        "Unseen angular acceleration, white-noise density", &ProcessNoise::angular_acceleration);
  noise("position_density", 10.0, "m/sqrt(s)",
        "Extra pose noise only where the state is carried without odometry (after the newest "
        "step, gaps); a frame inside an odometry interval uses that interval's own odometry",
        &ProcessNoise::position_density);
  noise("heading_density", 10.0, "rad/sqrt(s)", "The same for the heading",
        &ProcessNoise::heading_density);
  noise("odometry_velocity_sigma", 10.0, "m/s", "Extra noise of the velocity odometry measures",
        &ProcessNoise::odometry_velocity_sigma);
  noise("odometry_omega_sigma", 10.0, "rad/s", "Extra noise of the turn rate odometry measures",
        &ProcessNoise::odometry_omega_sigma);
}

void declareOdometry(SettingsTable<FC>& t) {
  t.section("odometry", "Layer 1 (seed 4.8): the covariance of a movement from the wheel ticks.");
  const auto odo = [&](const char* key, double min, double max, const char* unit, const char* why,
                       double OdometryNoise::*m) {
    t.add(std::string("odometry.") + key, min, max, unit, why, &FC::localizer, &LP::odometry, m);
  };
  odo("wheel_relative_sigma", 0.0, 1.0, "1",
      "Relative error of each wheel's travel (radius, carpet)",
      &OdometryNoise::wheel_relative_sigma);
  odo("wheel_slip_density", 0.0, 1.0, "1/sqrt(s)",
      "Wheel slip: a wheel that rolls d in dt is off by density * d / sqrt(dt); keeps NEES in band "
      "on the three scenarios' recordings with the bilinear floor renderer",
      &OdometryNoise::wheel_slip_density);
  odo("rotation_slip_density", 0.0, 10.0, "rad/s per m/s/sqrt(s)", "Random turning while driving",
      &OdometryNoise::rotation_slip_density);
  odo("translation_sigma_per_m", 0.0, 1.0, "m/m",
      "Slide beyond the wheels per metre driven: the match's position errors grow with the speed "
      "beyond what wheel slip explains (NEES in band on recorded matches)",
      &OdometryNoise::translation_sigma_per_m);
  odo("rotation_sigma_per_rad", 0.0, 1.0, "rad/rad", "Slide beyond the wheels per radian turned",
      &OdometryNoise::rotation_sigma_per_rad);
  odo("rotation_sigma_per_m", 0.0, 1.0, "rad/m", "Heading slide per metre driven",
      &OdometryNoise::rotation_sigma_per_m);
  odo("max_interval_s", 0.005, 10.0, "s", "Samples further apart are a gap: no velocity from them",
      &OdometryNoise::max_interval_s);
  odo("max_speed_factor", 1.0, 100.0, "1",
      "Wheel speeds above this multiple of the top speed are an odometry jump (refused)",
      &OdometryNoise::max_speed_factor);
  t.addBool("odometry.use_gyro",
            "Heading increments from the controller's gyro (ODOMETRY STATUS_GYRO) with its bias a "
            "filter state; false: the wheels' heading, as on a robot without a gyro",
            &FC::localizer, &LP::odometry, &OdometryNoise::use_gyro);
  odo("gyro_max_rate", 0.0, 1000.0, "rad/s",
      "A faster gyro increment is absurd: counted, the wheels' heading used; 0: 1.05 times the "
      "gyro's range",
      &OdometryNoise::gyro_max_rate);
  odo("gyro_heading_density", 0.0, 10.0, "rad/sqrt(s)",
      "Extra noise on the gyro's heading beyond its error model (stamps, twist between samples); "
      "0 made the heading overconfident (NEES in band 0.64 on a recorded match)",
      &OdometryNoise::gyro_heading_density);
}

// long: a table of declarations, one row per setting, read top to bottom like the YAML.
void declareLocalizer(SettingsTable<FC>& t) {
  t.section("localizer", "Lost detection, global localization and layer 3.");
  const auto num = [&](const char* key, auto min, auto max, const char* unit, const char* why,
                       auto m) {
    t.add(std::string("localizer.") + key, min, max, unit, why, &FC::localizer, m);
  };
  num("accept_cost_m", 0.001, 1.0, "m",
      "A frame whose corrected mean matching cost is at most this is a trusted correction",
      &LP::accept_cost_m);
  num("lost_cost_m", 0.001, 1.0, "m",
      "A frame whose cost at the estimate is above this contradicts it (at least accept_cost_m)",
      &LP::lost_cost_m);
  num("lost_frames", 1, 1000, "1", "Contradicting frames in a row before the robot counts as lost",
      &LP::lost_frames);
  num("contradict_min_points", std::size_t{1}, std::size_t{100000}, "1",
      "A frame with this many points contradicts the estimate even without a valid correction "
      "(from a heading far off, too few points lie near a line)",
      &LP::contradict_min_points);
  num("gated_frames_reset", 1, 1000, "1",
      "Trusted frames refused by the gate in a row before the filter restarts at the frame's pose",
      &LP::gated_frames_reset);
  num("slip_confirm_m", 0.0, 10.0, "m",
      "A gated frame is a slip when the frame before was gated too, disagreeing within this of it "
      "(one frame alone may be an aliased match; a collision keeps turning the robot)",
      &LP::slip_confirm_m);
  num("slip_confirm_rad", 0.0, 3.2, "rad", "The same in heading", &LP::slip_confirm_rad);
  num("slip_single_frame_rad", 0.0, 3.2, "rad",
      "... or at once when its heading disagrees by this: collisions twist the robot, aliased "
      "matches along a line shift it",
      &LP::slip_single_frame_rad);
  num("slip_pinned_ratio", 0.0, 100.0, "1",
      "A frame whose position sigmas differ by this ratio pins down only the direction across its "
      "long axis (a frame along one line)",
      &LP::slip_pinned_ratio);
  num("slip_pinned_chi2", 0.0, 1e6, "1",
      "Disagreement across the pinned direction beyond this (squared Mahalanobis) is a push: a "
      "slip at once; 0: off",
      &LP::slip_pinned_chi2);
  num("commit_frames", 1, 100, "1", "Frames a hypothesis is tested on before committing",
      &LP::commit_frames);
  num("commit_margin_m", 0.0, 1.0, "m", "A committed hypothesis' cost margin over the others",
      &LP::commit_margin_m);
  num("trust_frames", 0, 1000, "1",
      "Accepted corrections before a commit becomes the continuity reference of the next loss",
      &LP::trust_frames);
  num("twin_margin_m", 0.0, 30.0, "m",
      "The twin is told apart by continuity only with this margin (distance to the reference, "
      "m + 0.2 m/rad); else the commit is reported ambiguous",
      &LP::twin_margin_m);
  num("twin_margin_sigmas", 0.0, 100.0, "1",
      "... or this many sigmas of the reference's position, whichever is larger",
      &LP::twin_margin_sigmas);
  num("max_waiting_frames", std::size_t{1}, std::size_t{1000}, "1",
      "Line or feature frames newer than the newest odometry wait for it, at most this many "
      "(a starved motor bridge)",
      &LP::max_waiting_frames);
  t.addSeconds("localizer.max_wait_s", 0.05, 5.0,
               "... and at most this long; then they are used with the odometry there is",
               &FC::localizer, &LP::max_wait_us);
  num("feature_gate_m", 0.0, 20.0, "m",
      "A FIELD_FEATURES hypothesis this close to the estimate is fused (the likeliest of a frame)",
      &LP::feature_gate_m);
  num("feature_gate_rad", 0.0, 4.0, "rad", "The same in heading", &LP::feature_gate_rad);
  num("contradict_m", 0.0, 30.0, "m",
      "A confident feature hypothesis this far from the estimate and its twin contradicts it (at "
      "least feature_gate_m)",
      &LP::contradict_m);
  t.addSeconds("localizer.vision_timeout_s", 0.05, 60.0,
               "No VISION_LINES for this long: ODOMETRY_ONLY", &FC::localizer,
               &LP::vision_timeout_us);
  num("tracking_max_sigma_m", 0.0, 10.0, "m",
      "TRACKING only while the position sigma (largest axis) is within this; above it "
      "ODOMETRY_ONLY (0.5 m is about four sigma)",
      &LP::tracking_max_sigma_m);
  num("reset_confirm_frames", 0, 100, "1",
      "After a gated reset, SEARCHING until this many later frames are accepted",
      &LP::reset_confirm_frames);
  num("search_step_m", 0.05, 5.0, "m", "The coarse search's grid step when features are missing",
      &LP::search_step_m);
  num("search_headings", 4, 360, "1", "The coarse search's headings per turn",
      &LP::search_headings);
  num("search_points", 5, 10000, "1", "Points per pose the coarse search scores",
      &LP::search_points);
  num("max_hypotheses", std::size_t{1}, std::size_t{1000}, "1",
      "Hypotheses kept from a global search", &LP::max_hypotheses);
  num("local_search_s", 0.0, 10.0, "s",
      "After losing track, for this long the pose before the loss (carried by odometry) seeds "
      "hypotheses at heading offsets: a robot twisted by a collision is found in the next frame",
      &LP::local_search_s);
  num("local_search_step_rad", 0.01, 3.2, "rad", "The heading offsets' step",
      &LP::local_search_step_rad);
  num("local_search_steps", 0, 100, "1", "Heading offsets each side", &LP::local_search_steps);
  t.addChoice<StartPrior>("localizer.start_prior",
                          {{"own_half", StartPrior::kOwnHalf}, {"none", StartPrior::kNone}},
                          "Which symmetric twin to believe at start-up: own_half (robots enter at "
                          "x < 0) or none",
                          &FC::localizer, &LP::start_prior);
  num("resume_max_age_s", 0.0, 600.0, "s",
      "A fusion restarted within this of its last saved pose (--state-file) takes that pose, "
      "widened by the filter's slip reach over the gap, as the twin's reference; 0: never",
      &LP::resume_max_age_s);
  t.check({"localizer.lost_cost_m", "localizer.accept_cost_m"},
          [](const FC& c) -> std::optional<std::string> {
            if (c.localizer.lost_cost_m < c.localizer.accept_cost_m) {
              return "lost_cost_m must be at least accept_cost_m";
            }
            return std::nullopt;
          });
  // A hypothesis close enough to be fused must not also count as contradicting the estimate.
  t.check({"localizer.contradict_m", "localizer.feature_gate_m"},
          [](const FC& c) -> std::optional<std::string> {
            if (c.localizer.contradict_m < c.localizer.feature_gate_m) {
              return "contradict_m must be at least feature_gate_m";
            }
            return std::nullopt;
          });
}

void declareCalibration(SettingsTable<FC>& t) {
  t.section("calibration", "Covariance calibration (NEES): see docs/fusion.md, \"Consistency\".");
  const auto num = [&](const char* key, double min, double max, const char* unit, const char* why,
                       double LP::*m) {
    t.add(std::string("calibration.") + key, min, max, unit, why, &FC::localizer, m);
  };
  const auto slip = [&](const char* key, double min, double max, const char* unit, const char* why,
                        double SlipModel::*m) {
    t.add(std::string("calibration.") + key, min, max, unit, why, &FC::localizer, &LP::filter,
          &FP::slip, m);
  };
  num("correction_inflation", 0.01, 1e4, "1",
      "A layer-2 correction's covariance is the matcher's Hessian one times this (plus floors): "
      "keeps what the filter gets on the simulator's frames with correlated points counted once",
      &LP::correction_inflation);
  num("correction_floor_m", 0.0, 5.0, "m", "Floor of a correction's position sigma",
      &LP::correction_floor_m);
  num("correction_floor_rad", 0.0, 3.0, "rad",
      "Floor of a correction's heading sigma: frames' heading errors are correlated from frame to "
      "frame, and with the gyro's small heading noise the filter would average them as independent",
      &LP::correction_floor_rad);
  num("correction_cost_gain", 0.0, 1e3, "1", "Position sigma growing with the frame's mean cost",
      &LP::correction_cost_gain);
  num("correction_cost_gain_rad", 0.0, 1e3, "rad/m",
      "Heading sigma growing with the frame's mean cost", &LP::correction_cost_gain_rad);
  num("correction_stamp_sigma_s", 0.0, 1.0, "s",
      "A frame's stamp uncertainty: its covariance grows by this squared times the velocity's "
      "outer product (heading errors grow with the turn rate)",
      &LP::correction_stamp_sigma_s);
  num("commit_sigma_m", 0.0, 10.0, "m",
      "The pose committed after global localization is at least this uncertain",
      &LP::commit_sigma_m);
  num("commit_sigma_rad", 0.0, 3.2, "rad", "The same in heading", &LP::commit_sigma_rad);
  num("state_floor_m", 0.0, 5.0, "m", "Floor of the reported position sigma", &LP::state_floor_m);
  num("state_floor_rad", 0.0, 3.2, "rad", "Floor of the reported heading sigma",
      &LP::state_floor_rad);
  num("stamp_sigma_s", 0.0, 1.0, "s",
      "ROBOT_STATE's stamp (layer 1's sampling instant) is uncertain by a few ms, which in a "
      "collision's twist is degrees: the reported covariance grows by it times the velocity",
      &LP::stamp_sigma_s);
  slip("slip_max_m", 0.0, 10.0, "m",
       "Collisions and pushes: a trusted frame beyond the gate but within this of the estimate is "
       "applied with the covariance widened (0: off)",
       &SlipModel::max_m);
  slip("slip_max_rad", 0.0, 3.2, "rad", "The same in heading", &SlipModel::max_rad);
  slip("slip_max_rad_gyro", 0.0, 3.2, "rad",
       "... while the heading comes from the gyro; smaller values refused real slips (pushes with "
       "a heading error) on a recorded match",
       &SlipModel::max_rad_gyro);
  slip("slip_inflation", 0.0, 100.0, "1",
       "A slip widens the pose covariance by this times the disagreement squared",
       &SlipModel::inflation);
  slip("slip_max_speed", 0.0, 100.0, "m/s",
       "Since the last accepted correction the pose cannot have slipped farther than slip_base_m "
       "plus this times the time (opponents push at up to 3 m/s); 0: slip_max_m alone",
       &SlipModel::max_speed);
  slip("slip_base_m", 0.0, 10.0, "m", "The slip bound's base", &SlipModel::base_m);
  slip("gyro_heading_chi2", 0.0, 1e6, "1",
       "With the gyro, a frame's heading disagreeing beyond this (squared) is weighted down to "
       "this bound (Huber); its position still counts. 0: off; below filter.gate_chi2",
       &SlipModel::gyro_heading_chi2);
  num("heading_confirm_rad", 0.0, 3.2, "rad",
      "A next frame disagreeing in heading by the same within this is taken in full",
      &LP::heading_confirm_rad);
  // The Huber bound must lie inside the gate: at or beyond it, every weighted-down heading would
  // have been refused by the gate first.
  t.check({"calibration.gyro_heading_chi2", "filter.gate_chi2"},
          [](const FC& c) -> std::optional<std::string> {
            const double bound = c.localizer.filter.slip.gyro_heading_chi2;
            const double gate = c.localizer.filter.gate2;
            if (bound > 0.0 && gate > 0.0 && bound >= gate) {
              return "gyro_heading_chi2 must be below filter.gate_chi2 (" +
                     config::formatNumber(gate) + "), or 0 (off)";
            }
            return std::nullopt;
          });
}

void declareContact(SettingsTable<FC>& t) {
  t.section("contact",
            "Contact with another robot: evidence from the motor currents (and, if distance_m > 0, "
            "from the camera's nearest obstacle) widens the process noise and lets a well-matching "
            "frame beyond the gate be taken at once as a slip.");
  const auto model = [&](const char* key, double max, const char* unit, const char* why,
                         double ContactModel::*m) {
    t.add(std::string("contact.") + key, 0.0, max, unit, why, &FC::localizer, &LP::filter,
          &FP::contact, m);
  };
  t.add("contact.search_steps", 0, 20, "1",
        "A frame without a good correction (twisted beyond the matcher's reach) is matched again "
        "from the estimate turned by +-1..this times localizer.local_search_step_rad (0: off)",
        &FC::localizer, &LP::contact_search_steps);
  t.addBool("contact.search_always",
            "That heading search on every such frame, contact seen or not (contact evidence "
            "misses many twists)",
            &FC::localizer, &LP::twist_search_always);
  t.addBool("contact.search_with_gyro",
            "The heading search also while the heading comes from the gyro (off cost p99 17 -> 21 "
            "cm on a recorded match)",
            &FC::localizer, &LP::twist_search_with_gyro);
  t.add("contact.search_min_points", std::size_t{1}, std::size_t{100000}, "1",
        "Frames with fewer points are not searched", &FC::localizer,
        &LP::contact_search_min_points);
  model("distance_m", 5.0, "m",
        "Camera contact evidence: the nearest obstacle closer than this to the centre; 0: off, "
        "the motor currents are right far more often (a touching robot vanishes into the "
        "mirror's blind centre)",
        &ContactModel::distance_m);
  t.addSeconds("contact.hold_s", 0.0, 5.0, "Contact evidence lasts this long after its exposure",
               &FC::localizer, &LP::filter, &FP::contact, &ContactModel::hold_us);
  model("position_density", 10.0, "m/sqrt(s)", "Extra position process noise while in contact",
        &ContactModel::position_density);
  model("heading_density", 10.0, "rad/sqrt(s)",
        "Extra heading process noise while in contact (the simulator twists a touching robot by "
        "1.5 rad/sqrt(s) unseen by the wheels)",
        &ContactModel::heading_density);
  model("gyro_heading_density", 10.0, "rad/sqrt(s)",
        "... instead, while the heading comes from the gyro, which sees most of the twist",
        &ContactModel::gyro_heading_density);
  const auto push = [&](const char* key, double min, double max, const char* unit, const char* why,
                        double PushModel::*m) {
    t.add(std::string("contact.") + key, min, max, unit, why, &FC::localizer, &LP::filter,
          &FP::push, m);
  };
  push("push_density", 0.0, 100.0, "m/s/sqrt(s)",
       "The push velocity, two filter states: an opponent carries a touching robot at up to 3 m/s "
       "while its wheels slip; in contact a random walk of this density (0: off)",
       &PushModel::density);
  push("push_contact_decay_s", 0.001, 100.0, "s", "The push's decay time in contact",
       &PushModel::contact_decay_s);
  push("push_free_decay_s", 0.001, 100.0, "s", "The push's decay time outside contact",
       &PushModel::free_decay_s);
  push("push_max_speed", 0.0, 100.0, "m/s",
       "The push speed is held within this (a push learnt in a violent collision ran away)",
       &PushModel::max_speed);
  t.addSeconds("contact.push_unconfirmed_s", 0.0, 10.0,
               "Once the last accepted line correction is older, the push decays as outside "
               "contact: only frames tell it (0: no limit)",
               &FC::localizer, &LP::filter, &FP::push, &PushModel::unconfirmed_us);
  t.add("contact.current_force_n", 0.0, 1e4, "N",
        "Contact from the motor currents: a wheel's force beyond what its own acceleration needs, "
        "beyond this in current_samples samples in a row (0: off)",
        &FC::localizer, &LP::current_contact, &CurrentContactParams::force_threshold_n);
  t.add("contact.current_samples", 1, 100, "1", "Consecutive samples beyond current_force_n",
        &FC::localizer, &LP::current_contact, &CurrentContactParams::samples);
  t.add("contact.current_max_a", 0.1, 1e4, "A",
        "Currents beyond this or not finite are refused and counted", &FC::localizer,
        &LP::current_contact, &CurrentContactParams::max_current_a);
}

// long: a table of declarations, one row per setting, read top to bottom like the YAML.
void declareBall(SettingsTable<FC>& t) {
  t.section("ball", "The ball filter (constant velocity with rolling friction).");
  const auto num = [&](const char* key, auto min, auto max, const char* unit, const char* why,
                       auto m) {
    t.add(std::string("ball.") + key, min, max, unit, why, &FC::ball, m);
  };
  using BP = BallFilterParams;
  num("rolling_deceleration", 0.0, 20.0, "m/s^2", "Rolling friction", &BP::rolling_deceleration);
  num("acceleration_density", 0.0, 1000.0, "m/s^1.5",
      "Unseen acceleration of a rolling ball: kicks and bounces are steps the restart takes; "
      "between them a ball only rolls, and a low density averages the sightings' pose errors out",
      &BP::acceleration_density);
  num("rest_acceleration_density", 0.0, 1000.0, "m/s^1.5",
      "... of a ball at rest (slower than rest_speed_mps, its newest sighting within "
      "rest_max_nis): it only moves when hit, which the restart catches, so its sightings average "
      "(synthetic resting ball: 14 mm off with one density, 5 mm with two)",
      &BP::rest_acceleration_density);
  num("rest_speed_mps", 0.0, 10.0, "m/s", "... at rest: estimated slower than this",
      &BP::rest_speed_mps);
  num("rest_max_nis", 0.0, 1e6, "1",
      "... and its newest sighting within this (squared Mahalanobis distance, 2 dof); beyond, it "
      "started to roll",
      &BP::rest_max_nis);
  t.addBool("ball.rest_holds_place",
            "BALL_STATE of a ball at rest keeps the filter's position covariance at the last "
            "sighting (plus the resting model's growth): friction takes the velocity out, its "
            "uncertainty does not move the ball",
            &FC::ball, &BP::rest_holds_place);
  num("stamp_sigma_s", 0.0, 1.0, "s",
      "The reported covariance grows by this squared times the velocity's outer product: a "
      "rolling ball's place at a stamp is uncertain by its speed times the stamps' uncertainty "
      "(the line corrections' 8 ms; rolling balls seen from under 3 m are 3-8 ms times their "
      "speed off)",
      &BP::stamp_sigma_s);
  num("max_age_s", 0.05, 60.0, "s",
      "Invalid after this long unseen: a ball unseen for 15 frames within a few metres has "
      "usually left the constant-velocity model",
      &BP::max_age_s);
  t.addBool("ball.restart_when_expired",
            "A sighting after the estimate expired (max_age_s) starts the filter again, valid once "
            "a next sighting agrees, instead of updating the expired state (on: a robot whose "
            "heading is off re-acquires the ball where the expired state refused it; off by "
            "default, docs/teamcomm.md)",
            &FC::ball, &BP::restart_when_expired);
  num("gate_chi2", 0.1, 1e6, "1", "Outlier gate (chi^2, 2 dof)", &BP::gate2);
  num("restart_after_outliers", 1, 1000, "1", "Restart after this many outliers in a row",
      &BP::restart_after_outliers);
  num("max_range_m", 0.1, 50.0, "m", "Sightings further than this are not used", &BP::max_range_m);
  num("sighting_floor_m", 0.0, 5.0, "m",
      "Added in quadrature to the camera's sigmas; 0: the camera's own sigmas already cover the "
      "sightings' errors (a floor made a resting ball's sigma 5 cm against 1 cm errors)",
      &BP::sighting_floor_m);
  t.addBool("ball.invalid_after_outlier",
            "An outlier sighting (kicked, bounced, put back) makes the estimate invalid until a "
            "sighting agrees or the filter restarts",
            &FC::ball, &BP::invalid_after_outlier);
  num("unseen_range_m", 0.0, 20.0, "m",
      "Frames without the ball while the estimate lies within this of the robot (the omni camera "
      "sees all around) make it invalid (0: off)",
      &BP::unseen_range_m);
  num("unseen_frames", 1, 1000, "1", "... this many frames in a row", &BP::unseen_frames);
  num("restart_distance_m", 0.0, 50.0, "m",
      "A confident sighting further than this from the prediction restarts the filter at once "
      "(0: off; the outlier row restarts it)",
      &BP::restart_distance_m);
  num("restart_max_sigma_m", 0.001, 10.0, "m", "... confident: both sigmas at most this",
      &BP::restart_max_sigma_m);
  num("pose_max_unconfirmed_s", 0.0, 10.0, "s",
      "A sighting whose pose no line correction confirmed within this is only fused when it "
      "agrees (a twisted robot's sightings land metres away); 0: off",
      &BP::pose_max_unconfirmed_s);
  num("pose_max_correction_rad", 0.0, 4.0, "rad",
      "... nor when the next correction turned the heading by more", &BP::pose_max_correction_rad);
  t.addBool("ball.velocity_from_pair",
            "A restart takes its velocity from a path fitted through the row of outliers: a kicked "
            "ball is followed at once",
            &FC::ball, &BP::velocity_from_pair);
  num("pair_max_age_s", 0.001, 5.0, "s", "Outliers at most this older join the path",
      &BP::pair_max_age_s);
  num("fit_min_sightings", 2, 100, "1",
      "Sightings the path needs; from 3 on they must lie on it (two make a path even when one is "
      "false)",
      &BP::fit_min_sightings);
  num("pair_max_speed", 0.1, 100.0, "m/s", "A faster path is refused", &BP::pair_max_speed);
  num("restart_speed_sigma", 0.01, 100.0, "m/s", "Velocity sigma of a filter started at rest",
      &BP::restart_speed_sigma);
  num("settle_s", 0.0, 1.0, "s",
      "A sighting is fused again with the robot's newest pose for its time until this old: the "
      "same frame's line points, which arrive just after, correct that pose",
      &BP::settle_s);
  t.addBool("ball.smooth_pose",
            "The pose at a sighting's time takes the next line frame's correction, spread back "
            "linearly",
            &FC::ball, &BP::smooth_pose);
  t.add("ball.rate_hz", 1.0, 200.0, "Hz", "BALL_STATE messages per second", &FC::ball_rate_hz);
}

void declareTwinByTeam(SettingsTable<FC>& t) {
  t.section("twin_by_team",
            "Teammates' balls decide the twin: seen from the twin our ball lands at minus where "
            "the teammates see it; runs of votes confirm an ambiguous pose or move it.");
  t.add("twin_by_team.votes", 0, 1000, "1",
        "Votes in a row that confirm an ambiguous pose or move it to its twin (0: off)",
        &FC::localizer, &LP::twin_vote_run);
  t.addSeconds("twin_by_team.vote_gap_s", 0.1, 60.0, "A longer gap breaks a run of votes",
               &FC::localizer, &LP::twin_vote_gap_us);
  using TP = TeamBallVoteParams;
  t.add("twin_by_team.agree_m", 0.01, 5.0, "m",
        "A teammate's ball within this of ours agrees \"same\", of its mirror image \"twin\"",
        &FC::team_ball_vote, &TP::agree_m);
  t.add("twin_by_team.min_centre_distance_m", 0.02, 10.0, "m",
        "Only sightings at least this far from the centre spot are compared (larger than agree_m)",
        &FC::team_ball_vote, &TP::min_centre_distance_m);
  t.add("twin_by_team.max_sighting_sigma_m", 0.001, 10.0, "m",
        "A sighting votes only with its own sigma at most this", &FC::team_ball_vote,
        &TP::max_sighting_sigma_m);
  t.add("twin_by_team.min_teammates", 1, 5, "1",
        "Distinct teammates that must have agreed in the window, by more than two to one",
        &FC::team_ball_vote, &TP::min_teammates);
  t.addSeconds("twin_by_team.max_ball_age_s", 0.0, 5.0, "A teammate's ball seen within this",
               &FC::team_ball_vote, &TP::max_ball_age_us);
  t.addSeconds("twin_by_team.max_picture_gap_s", 0.0, 5.0,
               "... in a team picture within this of the sighting", &FC::team_ball_vote,
               &TP::max_picture_gap_us);
  t.addSeconds("twin_by_team.evidence_window_s", 0.0, 30.0,
               "Teammates seldom see the ball at once: an agreement counts for this long",
               &FC::team_ball_vote, &TP::evidence_window_us);
  t.check({"twin_by_team.min_centre_distance_m", "twin_by_team.agree_m"},
          [](const FC& c) -> std::optional<std::string> {
            if (c.team_ball_vote.min_centre_distance_m <= c.team_ball_vote.agree_m) {
              return "min_centre_distance_m must be larger than agree_m (else one teammate's ball "
                     "agrees with both our ball and its mirror image)";
            }
            return std::nullopt;
          });
}

}  // namespace

// long: a table of declarations, one row per setting, read top to bottom like the YAML.
const config::SettingsTable<MatcherParams>& matcherSettings() {
  static const auto table = [] {
    config::SettingsTable<MatcherParams> t;
    using MP = MatcherParams;
    t.section("", "Layer 2 (seed 4.11-4.12): docs/fusion.md, \"Layer 2 in detail\".");
    t.addChoice<MatchMethod>("method",
                             {{"force_field", MatchMethod::kForceField},
                              {"least_squares", MatchMethod::kRobustLeastSquares}},
                             "The thesis' force field or robust least squares on the distance grid",
                             &MP::method);
    t.addChoice<RobustLoss>("loss",
                            {{"huber", RobustLoss::kHuber}, {"cauchy", RobustLoss::kCauchy}},
                            "Least squares' robust loss", &MP::loss);
    t.add("grid_cell_m", 0.005, 0.5, "m", "The distance grid's cell", &MP::grid_cell_m);
    t.add("grid_margin_m", 0.0, 5.0, "m",
          "The grid reaches this beyond the carpet (at least outlier_distance_m)",
          &MP::grid_margin_m);
    t.add("outlier_distance_m", 0.01, 2.0, "m", "Points further from every line are outliers",
          &MP::outlier_distance_m);
    t.add("max_point_range_m", 0.1, 30.0, "m", "Points further from the robot are not used",
          &MP::max_point_range_m);
    t.add("point_sigma_m", 1e-4, 1.0, "m", "A line point's position sigma", &MP::point_sigma_m);
    t.add("correlation_length_m", 0.0, 5.0, "m",
          "Points closer than this along a line count as one in the covariance",
          &MP::correlation_length_m);
    t.add("range_weight_m", 0.0, 100.0, "m",
          "A point at range r weighs 1 / (1 + (r / this)^2): far points move most with a mirror "
          "slightly off (0: every point alike)",
          &MP::range_weight_m);
    t.add("camera_scale_sigma", 0.0, 0.5, "1",
          "The mirror's distance scale error; 0: the simulator's exact camera, a real robot sets "
          "its mirror calibration's figure",
          &MP::camera_scale_sigma);
    t.add("camera_tilt_sigma", 0.0, 0.5, "1", "The mirror's tilt error (as camera_scale_sigma)",
          &MP::camera_tilt_sigma);
    t.add("camera_axis_sigma_m", 0.0, 1.0, "m", "The mirror axis' offset error (as above)",
          &MP::camera_axis_sigma_m);
    t.add("min_inliers", 3, 100000, "1", "A correction needs at least this many inliers",
          &MP::min_inliers);
    t.add("min_inlier_fraction", 0.0, 1.0, "1", "... and this share of the points",
          &MP::min_inlier_fraction);
    t.add("max_valid_cost_m", 0.001, 10.0, "m", "A correction with a higher mean cost is invalid",
          &MP::max_valid_cost_m);
    t.add("runner_up_offset_m", 0.0, 5.0, "m",
          "The fit is restarted this far from the answer along its covariance axes to find the "
          "runner-up minimum (0: no search)",
          &MP::runner_up_offset_m);
    t.add("runner_up_offset_rad", 0.0, 3.2, "rad", "The runner-up search's heading offsets",
          &MP::runner_up_offset_rad);
    t.add("runner_up_distinct_m", 1e-3, 5.0, "m", "A runner-up this far away is a distinct minimum",
          &MP::runner_up_distinct_m);
    t.add("runner_up_distinct_rad", 1e-3, 3.2, "rad", "The same in heading",
          &MP::runner_up_distinct_rad);
    t.addBool(
        "shape_check",
        "Probe the cost 1.5 and 3 sigmas out along each covariance axis and widen an axis where it "
        "rises less than the Hessian's quadratic",
        &MP::shape_check);
    t.add("sigma_floor_m", 0.0, 1.0, "m",
          "What the distance grid resolves at best, added to the covariance", &MP::sigma_floor_m);
    t.add("sigma_floor_rad", 0.0, 1.0, "rad", "Floor of a correction's heading sigma",
          &MP::sigma_floor_rad);
    t.add("max_iterations", 1, 10000, "1", "Iterations of either method", &MP::max_iterations);
    t.add("converged_step", 1e-9, 0.1, "m", "A smaller step ends the iteration",
          &MP::converged_step);
    t.add("loss_scale_m", 1e-3, 2.0, "m", "The robust loss' scale", &MP::loss_scale_m);
    t.add("force_step", 1e-3, 2.0, "1", "Force field: translation step per force", &MP::force_step);
    t.add("moment_step", 1e-3, 2.0, "1", "Force field: rotation step per moment", &MP::moment_step);
    t.add("force_inertia", 0.0, 0.99, "1", "Force field: share of the last step kept",
          &MP::force_inertia);
    t.add("force_decay_per_m", 0.01, 1000.0, "1/m", "Force field: the force's decay (eta)",
          &MP::force_decay_per_m);
    t.add("force_cap_m", 0.01, 10.0, "m", "Force field: the force's cap (f_max)", &MP::force_cap_m);
    t.add("unobservable_sigma_m", 0.01, 1000.0, "m",
          "Sigma reported along a direction the points do not pin down", &MP::unobservable_sigma_m);
    t.add("unobservable_sigma_rad", 0.001, 100.0, "rad", "The same in heading",
          &MP::unobservable_sigma_rad);
    t.check({"grid_margin_m", "outlier_distance_m"}, [](const MP& p) -> std::optional<std::string> {
      if (p.grid_margin_m < p.outlier_distance_m) {
        return "grid_margin_m must be at least outlier_distance_m";
      }
      return std::nullopt;
    });
    return t;
  }();
  return table;
}

MatcherParams loadMatcherParams(const config::Node& node) {
  return matcherSettings().load(node);
}

const config::SettingsTable<FusionConfig>& fusionSettings() {
  static const auto table = [] {
    SettingsTable<FC> t;
    declareFilter(t);
    declareOdometry(t);
    declareLocalizer(t);
    declareCalibration(t);
    declareContact(t);
    declareBall(t);
    declareTwinByTeam(t);
    t.include("matcher", matcherSettings(), &FC::matcher);
    return t;
  }();
  return table;
}

std::string fusionConfigYaml(const FusionConfig& c) {
  return fusionSettings().yaml(
      c,
      "# fieldline-fusion settings (docs/fusion.md; every key: docs/settings/fusion.md).\n"
      "# Written by `fieldline-fusion --print-config --config none`: the values are the code's\n"
      "# defaults (services/fusion/fusion_config.cpp declares each once), and a test checks\n"
      "# that this file equals them. Every key is optional; an unknown key or a value out of\n"
      "# range stops the process with file:line. SI units: metres, radians, seconds.\n");
}

std::string fusionSettingsMarkdown() {
  return "# Fusion settings\n\n"
         "Every key of `config/fusion/*.yaml` (`fieldline-fusion --config`), with the code's "
         "default, which is what ships in `config/fusion/default.yaml`. Written by "
         "`fieldline-fusion --print-settings-table`; a test checks it against the declarations "
         "in `services/fusion/fusion_config.cpp`. What the filter does with them: "
         "[docs/fusion.md](../fusion.md).\n\n" +
         fusionSettings().markdown(FusionConfig{});
}

FusionConfig loadFusionConfig(const config::Node& root) {
  return fusionSettings().load(root);
}

FusionConfig loadFusionConfigPreset(const std::string& name_or_path) {
  if (name_or_path == "none") return FusionConfig{};
  return loadFusionConfig(config::Node::loadFile(config::resolvePreset("fusion", name_or_path)));
}

}  // namespace fieldline::fusion
