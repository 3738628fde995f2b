// fieldline-tracking-png as a library: one frame (an image file, raw YUYV, or a rendered drive)
// through the region tracker and its detectors, drawn for people (regions tinted, boundaries,
// line points, ball, obstacles) and written as data (line points as CSV in the robot frame, the
// format fieldline-features and fieldline-localize read, and as JSON with image coordinates).
// No bus, no clock.
#pragma once

#include <array>
#include <cmath>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/image_io.hpp"
#include "common/camera/mirror_model.hpp"
#include "services/region_tracking/frame_processor.hpp"

namespace fieldline::tracking_png {

// A rendered drive that ends at `pose` (x, y, phi in the field frame): `frames` frames driving
// at `speed` (m/s) while turning at `omega` (rad/s), so the last frame was tracked from the
// earlier ones.
struct RenderRequest {
  std::string field_preset = "msl";
  std::vector<double> pose{1.0, 0.5, 0.3};
  std::optional<std::array<double, 2>> ball;
  std::vector<std::array<double, 2>> robots;
  int frames = 1;
  double speed = 1.0, omega = M_PI / 2;
};

// A file: an image (PNG, JPEG, BMP...) or raw YUYV of `yuyv_size`; tracked `repeat` times (the
// tracker grows its regions from the first frame's seeds, so a still frame settles after a few).
struct FileRequest {
  std::string path;
  std::optional<camera::FrameSize> yuyv_size;
  int repeat = 5;
};

// The tracked last frame with everything needed to draw it. Not copyable (the processor refers
// to the mirror and table it owns).
struct TrackedFrame {
  camera::MirrorModel mirror{camera::MirrorParams{}};
  camera::ColourTable table;
  std::vector<std::uint8_t> rendered;  // the last rendered YUYV frame
  camera::FrameFile file;
  camera::FrameView view;
  std::unique_ptr<region_tracking::FrameProcessor> processor;
  region_tracking::VisionResult result;
};

// Loads the camera preset's mirror (scaled to a file's size when its aspect ratio matches) and
// its colour table (or `colour_table` when not empty), tracks, returns the last frame. Throws
// std::invalid_argument for a file whose size does not fit the camera, std::runtime_error for an
// unreadable file, config::Error for bad presets.
std::unique_ptr<TrackedFrame> trackFile(const std::string& camera_preset,
                                        const std::string& colour_table,
                                        const region_tracking::VisionParams& vision,
                                        const FileRequest& request);
std::unique_ptr<TrackedFrame> trackRendered(const std::string& camera_preset,
                                            const std::string& colour_table,
                                            const region_tracking::VisionParams& vision,
                                            const RenderRequest& request);

// The frame enlarged `scale` times with tracked cells tinted in their class colour, (with
// `touched`) the cells classified in the last frame outlined, boundaries (outer yellow, holes
// cyan), line points (red dots, each sequence joined), the ball (magenta cross), obstacles
// (black-and-white circles at their nearest floor point), and a caption.
cv::Mat drawTracking(const TrackedFrame& tracked, int scale, bool touched);

// The caption: touched share, overlap, line points, ball, obstacles.
std::string summary(const TrackedFrame& tracked);

// The frame's detections as one JSON object: image size, line point sequences with image (u, v,
// px) and robot-frame (x, y, m) coordinates, the ball, the obstacles.
void writeDetectionsJson(std::ostream& out, const TrackedFrame& tracked);

}  // namespace fieldline::tracking_png
