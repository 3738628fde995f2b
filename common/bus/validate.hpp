// Checks of every message type before it is handled or published: finite numbers, consistent
// sizes, values in their documented ranges. Returns what is wrong, or nothing.
#pragma once

#include <optional>
#include <string>

#include "common/bus/channels.hpp"

namespace fieldline::bus {

std::optional<std::string> validate(const header_t& m);
std::optional<std::string> validate(const image_t& m);
// validate(image_t) but the check that `data` holds `size` bytes (bus::ImageView's pixels are not
// in `data`).
std::optional<std::string> validateImageFields(const image_t& m);
std::optional<std::string> validate(const line_contours_t& m);
std::optional<std::string> validate(const ball_observation_t& m);
std::optional<std::string> validate(const obstacle_observations_t& m);
std::optional<std::string> validate(const field_features_t& m);
std::optional<std::string> validate(const odometry_t& m);
std::optional<std::string> validate(const motion_command_t& m);
std::optional<std::string> validate(const robot_state_t& m);
std::optional<std::string> validate(const ball_state_t& m);
std::optional<std::string> validate(const team_state_t& m);
std::optional<std::string> validate(const service_status_t& m);
std::optional<std::string> validate(const world_state_t& m);
std::optional<std::string> validate(const recording_info_t& m);

}  // namespace fieldline::bus
