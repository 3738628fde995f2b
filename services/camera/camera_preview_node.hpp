// CAMERA_PREVIEW (a node piece: it publishes): the camera's reduced stream for a viewer on another
// machine. Full frames (CAMERA_IMAGE, 18 MB/s at 640x480 YUYV and 30 Hz) stay on the robot; a copy
// at 1/kCameraPreviewScale of their width and height, a few times a second, goes out with the bus's
// ttl (docs/launch.md, "Watching from a laptop").
#pragma once

#include <fieldline/image_t.hpp>

#include "common/bus/node.hpp"

namespace fieldline::camera {

// `in` at 1/scale of its width and height: every scale-th pixel of every scale-th row (YUYV pairs
// keep the chroma of the pair their first pixel comes from; the width is made even). Header,
// frame number, source and exposure are copied. Throws std::invalid_argument for a frame whose
// sizes do not fit its data or an unknown format.
void reduceFrame(const image_t& in, int scale, image_t& out);

class PreviewPublisher {
 public:
  // At most `rate_hz` previews per second of frame time; 0: none. `bus`: where they go.
  PreviewPublisher(bus::Node& node, double rate_hz, bus::BusId bus = bus::kPrimaryBus);

  // After each published full frame: its reduced copy when one is due.
  void onFrame(const image_t& frame);
  std::int64_t published() const { return published_; }

 private:
  bus::Node& node_;
  Utime period_us_ = 0;
  bus::BusId bus_;
  Utime next_due_ = 0;
  image_t preview_{};
  std::int64_t published_ = 0;
};

}  // namespace fieldline::camera
