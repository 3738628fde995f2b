// robot_state_t (ROBOT_STATE), ball_state_t (BALL_STATE) and ball_observation_t (VISION_BALL)
// <-> the plain structs of common/perception/estimates.hpp. header.utime <-> utime.
#pragma once

#include <fieldline/ball_observation_t.hpp>
#include <fieldline/ball_state_t.hpp>
#include <fieldline/robot_state_t.hpp>

#include "common/perception/estimates.hpp"

namespace fieldline::msg {

perception::RobotEstimate fromMessage(const robot_state_t& m);
void toMessage(const perception::RobotEstimate& e, robot_state_t& m);

perception::BallEstimate fromMessage(const ball_state_t& m);
void toMessage(const perception::BallEstimate& e, ball_state_t& m);

perception::BallSighting fromMessage(const ball_observation_t& m);
void toMessage(const perception::BallSighting& s, ball_observation_t& m);

}  // namespace fieldline::msg
