#include "services/region_tracking/tracking_node.hpp"

#include <chrono>
#include <stdexcept>
#include <string>

namespace fieldline::region_tracking {

TrackingNode::TrackingNode(bus::Node& node, TrackingNodeOptions options)
    : node_(node), options_(std::move(options)) {
  if (options_.linesEveryFrames < 1) {
    throw std::invalid_argument("region tracking: lines_every_frames must be >= 1");
  }
  node_.subscribe(bus::channels::kCameraImage, [this](const image_t& image) { onImage(image); });
}

bool TrackingNode::prepareFor(int width, int height) {
  if (processor_ && mirror_->width() == width && mirror_->height() == height) return true;
  // A frame of a foreign size is refused without disturbing the tracking of the usual frames.
  // Everything for the new size is built aside and swapped in only when it all worked.
  std::unique_ptr<camera::MirrorModel> mirror;
  std::unique_ptr<FrameProcessor> processor;
  try {
    mirror = std::make_unique<camera::MirrorModel>(options_.mirror.scaledTo(width, height));
    processor = std::make_unique<FrameProcessor>(*mirror, options_.colours, options_.vision);
  } catch (const std::invalid_argument& e) {
    node_.reportError("frame_size",
                      std::to_string(width) + "x" + std::to_string(height) + ": " + e.what());
    return false;
  }
  processor_ = std::move(processor);
  mirror_ = std::move(mirror);
  return true;
}

void TrackingNode::onImage(const image_t& image) {
  ++frames_received_;
  camera::PixelFormat format;
  if (image.format == image_t::FORMAT_YUYV) {
    format = camera::PixelFormat::kYuyv;
  } else if (image.format == image_t::FORMAT_BGR) {
    format = camera::PixelFormat::kBgr;
  } else {
    ++frames_rejected_;
    node_.reportError("image_format", "CAMERA_IMAGE format " + std::to_string(image.format) +
                                          " is not YUYV or BGR");
    return;
  }
  const camera::FrameView view{image.data.data(), image.width, image.height, image.stride, format};
  if (!view.valid() || !prepareFor(image.width, image.height)) {
    ++frames_rejected_;
    if (!view.valid()) node_.reportError("image_layout", "CAMERA_IMAGE with an unusable layout");
    return;
  }

  // Every n-th processed frame: a rejected frame does not shift the cadence.
  const bool detectLines = frames_processed_ % options_.linesEveryFrames == 0;
  // Processing time is a measurement of this computer, not of the world: steady_clock.
  const auto start = std::chrono::steady_clock::now();
  processor_->process(view, detectLines, result_);
  const auto processingUs =
      static_cast<std::int32_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                    std::chrono::steady_clock::now() - start)
                                    .count());
  ++frames_processed_;

  publishBall(image, result_.ball);
  publishObstacles(image, result_.obstacles);
  if (detectLines) publishLines(image, result_, processingUs);
  node_.setMetric("touched_percent", 100.0 * result_.tracking.touchedFraction);
  node_.setMetric("processing_ms", processingUs / 1000.0);
}

void TrackingNode::publishLines(const image_t& image, const VisionResult& result,
                                std::int32_t processingUs) {
  line_contours_t& m = lines_;
  m.header.utime = image.header.utime;
  const auto& points = result.lines.points;
  m.num_points = static_cast<std::int32_t>(points.size());
  m.u.resize(points.size());
  m.v.resize(points.size());
  m.x.resize(points.size());
  m.y.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    m.u[i] = points[i].u;
    m.v[i] = points[i].v;
    m.x[i] = points[i].x;
    m.y[i] = points[i].y;
  }
  const auto& sequences = result.lines.sequences;
  m.num_sequences = static_cast<std::int32_t>(sequences.size());
  m.sequence_start.resize(sequences.size());
  m.sequence_end.resize(sequences.size());
  for (std::size_t i = 0; i < sequences.size(); ++i) {
    m.sequence_start[i] = sequences[i].first;
    m.sequence_end[i] = sequences[i].second;
  }
  m.image_width = image.width;
  m.image_height = image.height;
  m.cells_touched = result.tracking.cellsClassified;
  m.touched_fraction = static_cast<float>(result.tracking.touchedFraction);
  m.overlap_fraction = static_cast<float>(result.tracking.overlap);
  m.initial_searches = result.tracking.initialSearches;
  m.processing_us = processingUs;
  node_.publish(bus::channels::kVisionLines, m);
}

void TrackingNode::publishBall(const image_t& image, const BallDetection& ball) {
  ball_observation_t& m = ball_;
  m.header.utime = image.header.utime;
  m.visible = ball.visible;
  m.u = static_cast<float>(ball.visible ? ball.u : 0.0);
  m.v = static_cast<float>(ball.visible ? ball.v : 0.0);
  m.x = static_cast<float>(ball.visible ? ball.x : 0.0);
  m.y = static_cast<float>(ball.visible ? ball.y : 0.0);
  m.sigma_radial = static_cast<float>(ball.visible ? ball.sigmaRadial : 0.0);
  m.sigma_tangential = static_cast<float>(ball.visible ? ball.sigmaTangential : 0.0);
  m.cells = ball.visible ? ball.cells : 0;
  m.confidence = static_cast<float>(ball.visible ? ball.confidence : 0.0);
  node_.publish(bus::channels::kVisionBall, m);
}

void TrackingNode::publishObstacles(const image_t& image, const std::vector<Obstacle>& obstacles) {
  obstacle_observations_t& m = obstacles_;
  m.header.utime = image.header.utime;
  m.count = static_cast<std::int32_t>(obstacles.size());
  m.bearing.resize(obstacles.size());
  m.distance.resize(obstacles.size());
  m.angular_width.resize(obstacles.size());
  m.width.resize(obstacles.size());
  m.x.resize(obstacles.size());
  m.y.resize(obstacles.size());
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const Obstacle& o = obstacles[i];
    m.bearing[i] = static_cast<float>(o.bearing);
    m.distance[i] = static_cast<float>(o.distance);
    m.angular_width[i] = static_cast<float>(o.angularWidth);
    m.width[i] = static_cast<float>(o.width);
    m.x[i] = static_cast<float>(o.x);
    m.y[i] = static_cast<float>(o.y);
  }
  node_.publish(bus::channels::kVisionObstacles, m);
}

}  // namespace fieldline::region_tracking
