#include "services/region_tracking/tracking_node.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <stdexcept>
#include <string>

#include <spdlog/spdlog.h>
#include <Eigen/LU>

#include "common/msg/estimates.hpp"
#include "common/msg/image.hpp"
#include "common/msg/line_contours.hpp"
#include "common/msg/obstacle_observations.hpp"

namespace fieldline::region_tracking {

namespace {
// The status's keys, made once: set after every frame, the longer ones would allocate each time.
const std::string kTouchedPercent = "touched_percent";
const std::string kColourResets = "colour_resets";
const std::string kLightGain = "light_gain";
const std::string kVision = "vision";
const std::string kBallColour = "ball_colour";
const std::string kNoBallColour =
    "no ball colour calibrated (the colour table has no orange cells): no ball can be seen";
const std::string kGreenPercent = "green_percent";
const std::string kPointsOffLinePercent = "points_off_line_percent";
const std::string kLineCoveragePercent = "line_coverage_percent";
const std::string kProcessingMs = "processing_ms";
const std::string kNothing;
}  // namespace

TrackingNode::TrackingNode(bus::Node& node, TrackingNodeOptions options)
    : node_(node), options_(std::move(options)) {
  if (options_.lines_every_frames < 1) {
    throw std::invalid_argument("region tracking: lines_every_frames must be >= 1");
  }
  if (options_.adaptation.enabled) {
    adaptation_ = std::make_unique<ColourAdaptation>(options_.colours, options_.adaptation);
  }
  // The pixels are read where they arrived, not copied (issue 32).
  node_.subscribeImage(bus::channels::kCameraImage,
                       [this](const bus::ImageView& image) { onImage(image); });
  // Optional: without fusion the field checks and the ball's field check say nothing. Only the
  // newest state matters at the next frame: read deferred, it does not wake the process (50 Hz;
  // the waiting states are handled before the next frame, issue 32).
  node_.subscribeDeferred(bus::channels::kRobotState,
                          [this](const robot_state_t& state) { onRobotState(state); });
  // Without images this process does nothing: a dead camera must show in its status.
  node_.requireInput(
      bus::channels::kCameraImage,
      bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kCameraImage.name));
  node_.declareIo(trackingIo());
}

bus::ProcessIo trackingIo() {
  return bus::ProcessIo("region_tracking")
      .reads(bus::channels::kCameraImage)
      .readsIfPresent(bus::channels::kRobotState)
      .writes(bus::channels::kVisionLines)
      .writes(bus::channels::kVisionBall)
      .writes(bus::channels::kVisionObstacles);
}

void TrackingNode::onRobotState(const robot_state_t& state) {
  const perception::RobotEstimate e = msg::fromMessage(state);
  // The newest by its own time: a late, older state does not replace a newer one.
  if (robot_state_ && e.utime < robot_state_->utime) return;
  robot_state_ = e;
}

std::optional<FramePose> TrackingNode::poseAt(std::int64_t utime) const {
  if (!robot_state_ || robot_state_->status != perception::LocalizationStatus::kTracking) {
    return std::nullopt;
  }
  const perception::RobotEstimate& e = *robot_state_;
  const std::int64_t age = utime - e.utime;
  if (age > options_.max_pose_age_us || -age > options_.max_pose_age_us) return std::nullopt;
  const double dt = static_cast<double>(age) * 1e-6;
  FramePose out;
  out.pose = {e.pose.x + e.vx * dt, e.pose.y + e.vy * dt,
              geometry::normalizeAngle(e.pose.phi + e.omega * dt)};
  const Eigen::Matrix2d position = e.covariance.topLeftCorner<2, 2>();
  const double trace = position.trace();
  const double det = position.determinant();
  // The larger eigenvalue of the position covariance.
  const double larger = 0.5 * trace + std::sqrt(std::max(0.0, 0.25 * trace * trace - det));
  out.sigma_m = std::sqrt(std::max(0.0, larger));
  if (!geometry::isFinite(out.pose) || !std::isfinite(out.sigma_m)) return std::nullopt;
  return out;
}

bool TrackingNode::prepareFor(int width, int height) {
  if (processor_ && mirror_->width() == width && mirror_->height() == height) return true;
  // A frame of a foreign size is refused without disturbing the tracking of the usual frames.
  // Everything for the new size is built aside and swapped in only when it all worked.
  std::unique_ptr<camera::MirrorModel> mirror;
  std::unique_ptr<FrameProcessor> processor;
  std::unique_ptr<VisionHealth> health;
  try {
    mirror = std::make_unique<camera::MirrorModel>(options_.mirror.scaledTo(width, height));
    processor = std::make_unique<FrameProcessor>(*mirror, options_.colours, options_.vision);
    health = std::make_unique<VisionHealth>(*mirror, options_.colours, options_.health,
                                            options_.field.get(), &processor->classLookup());
  } catch (const std::invalid_argument& e) {
    node_.reportError("frame_size",
                      std::to_string(width) + "x" + std::to_string(height) + ": " + e.what());
    return false;
  }
  processor_ = std::move(processor);
  health_ = std::move(health);
  mirror_ = std::move(mirror);
  return true;
}

void TrackingNode::onImage(const bus::ImageView& frame) {
  const image_t& image = frame.fields;
  ++frames_received_;
  if (!msg::pixelFormatOf(image.format)) {
    ++frames_rejected_;
    node_.reportError("image_format", "CAMERA_IMAGE format " + std::to_string(image.format) +
                                          " is not YUYV or BGR");
    return;
  }
  const std::optional<camera::FrameView> view = msg::fromMessage(image, frame.data);
  if (!view || !prepareFor(image.width, image.height)) {
    ++frames_rejected_;
    if (!view) node_.reportError("image_layout", "CAMERA_IMAGE with an unusable layout");
    return;
  }

  // Every n-th processed frame: a rejected frame does not shift the cadence.
  const bool detectLines = frames_processed_ % options_.lines_every_frames == 0;
  // Processing time is a measurement of this computer, not of the world: steady_clock.
  // Fusion's pose at the frame's time: where a ball can be, and (below) do the points fit.
  const std::optional<FramePose> pose = poseAt(image.header.utime);
  if (options_.field && pose) {
    processor_->setBallRegion(BallRegion{options_.field.get(), pose->pose, pose->sigma_m});
  } else {
    processor_->setBallRegion(std::nullopt);
  }
  const auto start = std::chrono::steady_clock::now();
  processor_->process(*view, detectLines, result_);
  const auto measuredUs =
      static_cast<std::int32_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                    std::chrono::steady_clock::now() - start)
                                    .count());
  const std::int32_t processingUs = options_.report_processing_time ? measuredUs : 0;
  ++frames_processed_;

  publishBall(image, result_.ball);
  publishObstacles(image, result_.obstacles);
  if (detectLines) publishLines(image, result_, processingUs);
  node_.setMetric(kTouchedPercent, 100.0 * result_.tracking.touched_fraction);
  // Blind or degraded vision is a WARN with its reason, ok again once the frames fit.
  if (colour_reset_requested_.exchange(false)) {
    if (adaptation_) {
      adaptation_->reset(options_.colours);
      processor_->coloursChanged();
      ++colour_resets_;
      node_.setMetric(kColourResets, static_cast<double>(colour_resets_));
      spdlog::info("colour adaptation reset on demand: back to the calibrated table ({} so far)",
                   colour_resets_);
    } else {
      spdlog::warn("colour adaptation reset requested, but the adaptation is off: nothing to do");
    }
  }
  if (adaptation_) {
    if (adaptation_->observe(*view, processor_->tracker(), options_.colours)) {
      processor_->coloursChanged();
    }
    node_.setMetric(kLightGain, adaptation_->appliedGain());
  }
  health_->update(*view, result_, pose);
  node_.status().setWarning(kVision, health_->reason());
  // The ball's colour comes from the calibration (the table's orange cells); without any, no
  // ball can be found, and the status says so rather than reporting an empty field.
  node_.status().setWarning(kBallColour,
                            processor_->ballDetector().hasBallColour() ? kNothing : kNoBallColour);
  node_.setMetric(kGreenPercent, 100.0 * health_->greenFraction());
  // The field checks' figures (-1: not judged, no pose or too few facts).
  const auto percent = [](double share) { return share < 0.0 ? -1.0 : 100.0 * share; };
  node_.setMetric(kPointsOffLinePercent, percent(health_->offLineShare()));
  node_.setMetric(kLineCoveragePercent, percent(health_->lineCoverage()));
  node_.setMetric(kProcessingMs, measuredUs / 1000.0);
}

namespace {
std::atomic<TrackingNode*> g_reset_target{nullptr};
static_assert(std::atomic<TrackingNode*>::is_always_lock_free);
static_assert(std::atomic<bool>::is_always_lock_free);

void onColourResetSignal(int) {
  // Async-signal-safe: a lock-free load and a lock-free store.
  if (TrackingNode* node = g_reset_target.load()) node->requestColourReset();
}
}  // namespace

TrackingNode::~TrackingNode() {
  TrackingNode* self = this;
  g_reset_target.compare_exchange_strong(self, nullptr);
}

void installColourResetSignal(TrackingNode& node) {
  g_reset_target.store(&node);
  struct sigaction sa {};
  sa.sa_handler = onColourResetSignal;
  sa.sa_flags = SA_RESTART;
  sigemptyset(&sa.sa_mask);
  if (sigaction(SIGUSR1, &sa, nullptr) != 0) {
    throw std::runtime_error("region tracking: cannot install the SIGUSR1 handler");
  }
}

void TrackingNode::publishLines(const image_t& image, const VisionResult& result,
                                std::int32_t processingUs) {
  line_contours_t& m = lines_;
  m.header.utime = image.header.utime;
  msg::toMessage(result.lines, m);
  m.image_width = image.width;
  m.image_height = image.height;
  m.cells_touched = result.tracking.cells_classified;
  m.touched_fraction = static_cast<float>(result.tracking.touched_fraction);
  m.overlap_fraction = static_cast<float>(result.tracking.overlap);
  m.initial_searches = result.tracking.initial_searches;
  m.processing_us = processingUs;
  node_.publish(bus::channels::kVisionLines, m);
}

void TrackingNode::publishBall(const image_t& image, const BallDetection& ball) {
  perception::BallSighting sighting;
  sighting.utime = image.header.utime;
  sighting.visible = ball.visible;
  sighting.u = ball.u;
  sighting.v = ball.v;
  sighting.x = ball.x;
  sighting.y = ball.y;
  sighting.sigma_radial = ball.sigma_radial;
  sighting.sigma_tangential = ball.sigma_tangential;
  sighting.cells = ball.cells;
  sighting.confidence = ball.confidence;
  msg::toMessage(sighting, ball_);
  node_.publish(bus::channels::kVisionBall, ball_);
}

void TrackingNode::publishObstacles(const image_t& image, const std::vector<Obstacle>& obstacles) {
  obstacle_sightings_.utime = image.header.utime;
  obstacle_sightings_.obstacles.resize(obstacles.size());
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const Obstacle& o = obstacles[i];
    obstacle_sightings_.obstacles[i] = {o.bearing, o.distance, o.angular_width, o.width, o.x, o.y};
  }
  msg::toMessage(obstacle_sightings_, obstacles_);
  node_.publish(bus::channels::kVisionObstacles, obstacles_);
}

}  // namespace fieldline::region_tracking
