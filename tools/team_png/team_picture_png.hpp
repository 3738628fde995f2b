// Draws one robot's team picture (TEAM_STATE, as plain perception::TeamState) on the field:
// every present robot at its pose with its 2-sigma circle (robot `self` outlined in white), each
// robot's own ball (small, in its colour), the fused team ball (orange, with its 2-sigma
// ellipse) and, when given, the simulator's truth as grey rings, with a legend of ages and clock
// offsets. No bus: fieldline-team-png feeds it, the unit test checks its pixels.
#pragma once

#include <array>

#include <opencv2/core.hpp>

#include "common/field/field_model.hpp"
#include "common/perception/team.hpp"
#include "common/perception/world_truth.hpp"

namespace fieldline::team_png {

// BGR colour of robot i+1.
extern const std::array<cv::Scalar, 6> kRobotColours;
// BGR colour of the team ball.
inline const cv::Scalar kTeamBallColour{0, 140, 255};
// Height of the legend strip below the field, pixels.
inline constexpr int kLegendRows = 64;

// `truth` may be null. The image is the carpet at `px_per_m` plus the legend strip.
cv::Mat drawTeamPicture(const field::FieldModel& field, const perception::TeamState& picture,
                        int self, const perception::WorldTruth* truth, double px_per_m);

// Pixel of field point p in that image.
cv::Point fieldPixel(const field::FieldModel& field, double px_per_m, const field::Vec2& p);

}  // namespace fieldline::team_png
