// The one table of channel names. A process never spells a channel name anywhere else: it
// subscribes and publishes through these constants, which also fix the message type.
#pragma once

#include <array>
#include <string_view>

#include <fieldline/ball_observation_t.hpp>
#include <fieldline/ball_state_t.hpp>
#include <fieldline/field_features_t.hpp>
#include <fieldline/image_t.hpp>
#include <fieldline/line_contours_t.hpp>
#include <fieldline/motion_command_t.hpp>
#include <fieldline/obstacle_observations_t.hpp>
#include <fieldline/odometry_t.hpp>
#include <fieldline/recording_info_t.hpp>
#include <fieldline/robot_state_t.hpp>
#include <fieldline/service_status_t.hpp>
#include <fieldline/team_state_t.hpp>
#include <fieldline/world_state_t.hpp>

namespace fieldline::bus {

// A channel name bound to its message type.
template <typename Msg>
struct Channel {
  using Message = Msg;
  std::string_view name;
  // Its place in kAllChannelNames below (-1: a name outside the table): the node finds its
  // sequence numbers and statistics by it, without comparing names per message.
  int index = -1;
};

namespace channels {
// Robot bus (one per robot).
inline constexpr Channel<image_t> kCameraImage{"CAMERA_IMAGE", 0};
// The camera's reduced stream for a viewer on another machine (every kCameraPreviewScale-th pixel
// of every kCameraPreviewScale-th row, a few frames a second): CAMERA_IMAGE never leaves the
// robot, this does when the bus has a ttl (docs/launch.md, "Watching from a laptop").
inline constexpr Channel<image_t> kCameraPreview{"CAMERA_PREVIEW", 13};
inline constexpr Channel<line_contours_t> kVisionLines{"VISION_LINES", 1};
inline constexpr Channel<ball_observation_t> kVisionBall{"VISION_BALL", 2};
inline constexpr Channel<obstacle_observations_t> kVisionObstacles{"VISION_OBSTACLES", 3};
inline constexpr Channel<field_features_t> kFieldFeatures{"FIELD_FEATURES", 4};
inline constexpr Channel<odometry_t> kOdometry{"ODOMETRY", 5};
inline constexpr Channel<motion_command_t> kMotionCommand{"MOTION_COMMAND", 6};
inline constexpr Channel<robot_state_t> kRobotState{"ROBOT_STATE", 7};
inline constexpr Channel<ball_state_t> kBallState{"BALL_STATE", 8};
inline constexpr Channel<team_state_t> kTeamState{"TEAM_STATE", 9};
// Every bus, from every process.
inline constexpr Channel<service_status_t> kServiceStatus{"SERVICE_STATUS", 10};
// Simulator bus only: ground truth.
inline constexpr Channel<world_state_t> kSimWorld{"SIM_WORLD", 11};
// Recordings only (never on a bus): what fieldline-record writes into each file about it.
inline constexpr Channel<recording_info_t> kRecordingInfo{"RECORDING_INFO", 12};
}  // namespace channels

// CAMERA_PREVIEW's width and height are CAMERA_IMAGE's divided by this.
inline constexpr int kCameraPreviewScale = 4;

// Every channel name, for tools that list or record them.
// New channels go at the end: the fuzz corpus picks a channel by its index here.
inline constexpr std::array<std::string_view, 14> kAllChannelNames{
    channels::kCameraImage.name,     channels::kVisionLines.name,   channels::kVisionBall.name,
    channels::kVisionObstacles.name, channels::kFieldFeatures.name, channels::kOdometry.name,
    channels::kMotionCommand.name,   channels::kRobotState.name,    channels::kBallState.name,
    channels::kTeamState.name,       channels::kServiceStatus.name, channels::kSimWorld.name,
    channels::kRecordingInfo.name,   channels::kCameraPreview.name};

// The place of `name` in kAllChannelNames, or -1.
constexpr int channelIndex(std::string_view name) {
  for (std::size_t i = 0; i < kAllChannelNames.size(); ++i)
    if (kAllChannelNames[i] == name) return static_cast<int>(i);
  return -1;
}
static_assert(channelIndex(channels::kCameraImage.name) == channels::kCameraImage.index &&
              channelIndex(channels::kVisionLines.name) == channels::kVisionLines.index &&
              channelIndex(channels::kVisionBall.name) == channels::kVisionBall.index &&
              channelIndex(channels::kVisionObstacles.name) == channels::kVisionObstacles.index &&
              channelIndex(channels::kFieldFeatures.name) == channels::kFieldFeatures.index &&
              channelIndex(channels::kOdometry.name) == channels::kOdometry.index &&
              channelIndex(channels::kMotionCommand.name) == channels::kMotionCommand.index &&
              channelIndex(channels::kRobotState.name) == channels::kRobotState.index &&
              channelIndex(channels::kBallState.name) == channels::kBallState.index &&
              channelIndex(channels::kTeamState.name) == channels::kTeamState.index &&
              channelIndex(channels::kServiceStatus.name) == channels::kServiceStatus.index &&
              channelIndex(channels::kSimWorld.name) == channels::kSimWorld.index &&
              channelIndex(channels::kRecordingInfo.name) == channels::kRecordingInfo.index &&
              channelIndex(channels::kCameraPreview.name) == channels::kCameraPreview.index);

// The rate each channel is published at in normal operation (docs: the channel table), Hz; 0 for
// channels without a fixed rate. A process requires its inputs at a fraction of this
// (Node::requireInput), so a slow machine is not a warning but a dead input is.
constexpr double nominalRateHz(std::string_view channel) {
  if (channel == channels::kCameraImage.name) return 30.0;
  if (channel == channels::kVisionLines.name) return 10.0;
  if (channel == channels::kVisionBall.name) return 30.0;
  if (channel == channels::kVisionObstacles.name) return 30.0;
  if (channel == channels::kFieldFeatures.name) return 10.0;
  if (channel == channels::kOdometry.name) return 50.0;
  if (channel == channels::kMotionCommand.name) return 30.0;
  if (channel == channels::kRobotState.name) return 50.0;
  if (channel == channels::kBallState.name) return 30.0;
  if (channel == channels::kTeamState.name) return 10.0;
  if (channel == channels::kServiceStatus.name) return 1.0;
  if (channel == channels::kSimWorld.name) return 100.0;
  return 0.0;
}
// Channels whose messages may be larger than one UDP datagram (~64 KB), which LCM then sends in
// fragments: images and point sequences. The others are bounded far below that. Later fragments
// name no channel: a process reading one of these takes later fragments from the senders it has
// seen publishing one of them (or every later fragment, usuallyNeedsSeveralDatagrams); every other
// process never wakes for a fragment it does not read (udpm_receiver.hpp).
constexpr bool mayNeedSeveralDatagrams(std::string_view channel) {
  return channel == channels::kCameraImage.name || channel == channels::kCameraPreview.name ||
         channel == channels::kVisionLines.name || channel == channels::kFieldFeatures.name;
}
// Of those, the channels whose every message takes several datagrams (a 320x240 image is 150 KB):
// a process reading one takes every later fragment on its bus, so that it has a sender's first
// message whole too. The others fit one datagram at the shipped sizes (a frame's line points,
// its features) and mostly begin a sender's traffic with a message of one datagram.
constexpr bool usuallyNeedsSeveralDatagrams(std::string_view channel) {
  return channel == channels::kCameraImage.name;
}

// The fraction of the nominal rate below which an input counts as failing.
inline constexpr double kRequiredRateFraction = 0.5;

}  // namespace fieldline::bus
