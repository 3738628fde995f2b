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

// Every channel name, for tools that list or record them; a channel's place here is its index.
// New channels go at the end: the fuzz corpus picks a channel by its index here.
inline constexpr std::array<std::string_view, 14> kAllChannelNames{
    "CAMERA_IMAGE",   "VISION_LINES",   "VISION_BALL",    "VISION_OBSTACLES", "FIELD_FEATURES",
    "ODOMETRY",       "MOTION_COMMAND", "ROBOT_STATE",    "BALL_STATE",       "TEAM_STATE",
    "SERVICE_STATUS", "SIM_WORLD",      "RECORDING_INFO", "CAMERA_PREVIEW"};

// The place of `name` in kAllChannelNames, or -1.
constexpr int channelIndex(std::string_view name) {
  for (std::size_t i = 0; i < kAllChannelNames.size(); ++i)
    if (kAllChannelNames[i] == name) return static_cast<int>(i);
  return -1;
}

// A channel name bound to its message type.
template <typename Msg>
struct Channel {
  using Message = Msg;
  std::string_view name;
  // Its place in kAllChannelNames (-1: a name outside the table): the node finds its sequence
  // numbers and statistics by it, without comparing names per message. The constants below take
  // it from the name (tableChannel<Msg>(name)); a Channel made by hand is trusted only where the
  // table has its name at that place (Node::outlet).
  int index = -1;
};

// The channel of the table named `name`, its index found at compile time: a name the table does
// not hold does not compile.
template <typename Msg>
consteval Channel<Msg> tableChannel(std::string_view name) {
  const int index = channelIndex(name);
  if (index < 0) throw "a channel constant needs its name in kAllChannelNames";
  return Channel<Msg>{name, index};
}

namespace channels {
// Robot bus (one per robot).
inline constexpr auto kCameraImage = tableChannel<image_t>("CAMERA_IMAGE");
// The camera's reduced stream for a viewer on another machine (every kCameraPreviewScale-th pixel
// of every kCameraPreviewScale-th row, a few frames a second): CAMERA_IMAGE never leaves the
// robot, this does when the bus has a ttl (docs/launch.md, "Watching from a laptop").
inline constexpr auto kCameraPreview = tableChannel<image_t>("CAMERA_PREVIEW");
inline constexpr auto kVisionLines = tableChannel<line_contours_t>("VISION_LINES");
inline constexpr auto kVisionBall = tableChannel<ball_observation_t>("VISION_BALL");
inline constexpr auto kVisionObstacles = tableChannel<obstacle_observations_t>("VISION_OBSTACLES");
inline constexpr auto kFieldFeatures = tableChannel<field_features_t>("FIELD_FEATURES");
inline constexpr auto kOdometry = tableChannel<odometry_t>("ODOMETRY");
inline constexpr auto kMotionCommand = tableChannel<motion_command_t>("MOTION_COMMAND");
inline constexpr auto kRobotState = tableChannel<robot_state_t>("ROBOT_STATE");
inline constexpr auto kBallState = tableChannel<ball_state_t>("BALL_STATE");
inline constexpr auto kTeamState = tableChannel<team_state_t>("TEAM_STATE");
// Every bus, from every process.
inline constexpr auto kServiceStatus = tableChannel<service_status_t>("SERVICE_STATUS");
// Simulator bus only: ground truth.
inline constexpr auto kSimWorld = tableChannel<world_state_t>("SIM_WORLD");
// Recordings only (never on a bus): what fieldline-record writes into each file about it.
inline constexpr auto kRecordingInfo = tableChannel<recording_info_t>("RECORDING_INFO");
}  // namespace channels

// CAMERA_PREVIEW's width and height are CAMERA_IMAGE's divided by this.
inline constexpr int kCameraPreviewScale = 4;

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
