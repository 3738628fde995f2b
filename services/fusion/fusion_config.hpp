// The fusion process's settings in one YAML file (config/fusion/default.yaml): the filter's
// window and gate, the process and odometry noise, the localizer's thresholds, the covariance
// calibration (floors, slip and collision inflation, the uncertainty of a committed pose), contact
// evidence from VISION_OBSTACLES, the ball filter and layer 2's matcher. Every key is optional
// (absent keys keep the code's defaults); an unknown key or a value out of range is an error with
// file:line.
#pragma once

#include <string>

#include "common/config/config.hpp"
#include "services/fusion/ball_filter.hpp"
#include "services/fusion/line_matcher.hpp"
#include "services/fusion/localizer.hpp"
#include "services/fusion/team_twin.hpp"

namespace fieldline::fusion {

struct FusionConfig {
  LocalizerParams localizer;
  BallFilterParams ball;
  MatcherParams matcher;
  TeamBallVoteParams team_ball_vote;
  // BALL_STATE messages per second.
  double ball_rate_hz = 30.0;
};

// Reads the root of a fusion config file: sections filter, process_noise, odometry, localizer,
// calibration, contact, ball, twin_by_team, matcher (each optional).
FusionConfig loadFusionConfig(const config::Node& root);
// Preset name (config/fusion/NAME.yaml) or path.
FusionConfig loadFusionConfigPreset(const std::string& name_or_path);

}  // namespace fieldline::fusion
