// The region_tracking process's bus side: CAMERA_IMAGE in; VISION_BALL and VISION_OBSTACLES for
// every frame and VISION_LINES every n-th frame out, each stamped with the frame's utime (the
// exposure time), so fusion can line them up with odometry. ROBOT_STATE (fusion's pose, when it
// runs) in: with the field model it tells the vision health whether the points fit the field and
// the ball detector where a ball can be.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <fieldline/ball_observation_t.hpp>
#include <fieldline/image_t.hpp>
#include <fieldline/line_contours_t.hpp>
#include <fieldline/obstacle_observations_t.hpp>
#include <fieldline/robot_state_t.hpp>

#include "common/bus/node.hpp"
#include "common/camera/colour.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/perception/estimates.hpp"
#include "common/perception/obstacles.hpp"
#include "services/region_tracking/colour_adaptation.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "services/region_tracking/vision_health.hpp"

namespace fieldline::region_tracking {

struct TrackingNodeOptions {
  // The camera's mirror for its configured image size; frames of another size with the same
  // aspect ratio get a scaled copy.
  camera::MirrorModel mirror{camera::MirrorParams{}};
  camera::ColourTable colours;
  VisionParams vision = defaultVisionParams();
  // When the vision counts as blind or degraded (SERVICE_STATUS WARN with the reason).
  VisionHealthParams health;
  // The field the robot plays on; null: no field checks, no ball-on-the-field check.
  std::shared_ptr<const field::FieldModel> field;
  // A ROBOT_STATE is used for a frame up to this far from the frame's time (extrapolated with its
  // velocity), µs.
  std::int64_t max_pose_age_us = 500'000;
  // Green and white follow slow changes of light (colour_adaptation.hpp); off by default.
  ColourAdaptationParams adaptation;
  // Field lines are extracted on every n-th frame (the seed's 10 Hz at 30 fps).
  int lines_every_frames = 3;
  // VISION_LINES.processing_us is the one output that depends on this machine, not on the
  // frames: replays that compare outputs byte for byte turn it off (it is then 0).
  bool report_processing_time = true;
};

// What region tracking reads and writes (fieldline-region-tracking --print-io).
bus::ProcessIo trackingIo();

class TrackingNode {
 public:
  // Subscribes CAMERA_IMAGE on `node`'s primary bus. Throws std::invalid_argument for
  // lines_every_frames < 1.
  TrackingNode(bus::Node& node, TrackingNodeOptions options);
  // No longer the target of installColourResetSignal().
  ~TrackingNode();
  TrackingNode(const TrackingNode&) = delete;
  TrackingNode& operator=(const TrackingNode&) = delete;

  std::int64_t framesProcessed() const { return frames_processed_; }
  std::int64_t framesRejected() const { return frames_rejected_; }
  // Empty while the vision looks healthy (vision_health.hpp), else why it does not.
  std::string healthReason() const { return health_ ? health_->reason() : std::string(); }
  // Reset on demand of the colour adaptation: before the next frame the table returns to the
  // calibrated one and the adaptation measures a new reference (ColourAdaptation::reset).
  // Only sets a flag, so it may be called from a signal handler or another thread; with the
  // adaptation off it is logged and ignored. Resets done so far: the metric `colour_resets`.
  void requestColourReset() { colour_reset_requested_.store(true); }
  std::int64_t colourResets() const { return colour_resets_; }
  // Fusion's pose at `utime` (the newest ROBOT_STATE while TRACKING, moved by its velocity), when
  // known and recent enough.
  std::optional<FramePose> poseAt(std::int64_t utime) const;

 private:
  void onImage(const bus::ImageView& frame);
  void onRobotState(const robot_state_t& state);
  bool prepareFor(int width, int height);
  void publishLines(const image_t& image, const VisionResult& result, std::int32_t processingUs);
  void publishBall(const image_t& image, const BallDetection& ball);
  void publishObstacles(const image_t& image, const std::vector<Obstacle>& obstacles);

  bus::Node& node_;
  TrackingNodeOptions options_;
  // For the size of the frames currently arriving.
  // Owned by pointer: the processor keeps a reference to it.
  std::unique_ptr<camera::MirrorModel> mirror_;
  std::unique_ptr<FrameProcessor> processor_;
  std::unique_ptr<VisionHealth> health_;
  // Adapts options_.colours in place (the processor classifies with it); null when off.
  std::unique_ptr<ColourAdaptation> adaptation_;
  VisionResult result_;
  line_contours_t lines_{};
  ball_observation_t ball_{};
  obstacle_observations_t obstacles_{};
  perception::ObstacleSightings obstacle_sightings_;
  std::int64_t frames_received_ = 0;
  std::int64_t frames_processed_ = 0;
  std::int64_t frames_rejected_ = 0;
  std::optional<perception::RobotEstimate> robot_state_;
  std::atomic<bool> colour_reset_requested_{false};
  std::int64_t colour_resets_ = 0;
};

// SIGUSR1 calls node.requestColourReset() (`kill -USR1 <pid>` resets the colour adaptation of a
// running process). One node per process; installing again replaces the previous one.
void installColourResetSignal(TrackingNode& node);

}  // namespace fieldline::region_tracking
