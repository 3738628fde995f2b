#include "services/camera/camera_preview_node.hpp"

#include "common/bus/validate.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace fieldline::camera {

void reduceFrame(const image_t& in, int scale, image_t& out) {
  if (scale < 1) throw std::invalid_argument("preview: scale must be at least 1");
  // The same checks as every received image (common/bus/validate).
  if (const auto problem = bus::validate(in)) throw std::invalid_argument("preview: " + *problem);
  const int bytes_per_pixel = in.format == image_t::FORMAT_YUYV  ? 2
                              : in.format == image_t::FORMAT_BGR ? 3
                                                                 : 1;
  int width = in.width / scale;
  if (in.format == image_t::FORMAT_YUYV) width -= width % 2;
  const int height = in.height / scale;
  if (width < 2 || height < 1) throw std::invalid_argument("preview: the frame is too small");
  out.header = in.header;
  out.width = width;
  out.height = height;
  out.stride = width * bytes_per_pixel;
  out.format = in.format;
  out.source = in.source;
  out.frame_number = in.frame_number;
  out.exposure_us = in.exposure_us;
  out.size = out.stride * height;
  out.data.resize(static_cast<std::size_t>(out.size));
  for (int v = 0; v < height; ++v) {
    const std::uint8_t* row = in.data.data() + static_cast<std::size_t>(v * scale) * in.stride;
    std::uint8_t* o = out.data.data() + static_cast<std::size_t>(v) * out.stride;
    if (in.format == image_t::FORMAT_YUYV) {
      for (int k = 0; k < width / 2; ++k) {
        // Output pixels 2k and 2k+1 are input pixels 2k*scale and (2k+1)*scale.
        const std::uint8_t* first = row + static_cast<std::size_t>(2 * k * scale) * 2;
        const std::uint8_t* second = row + static_cast<std::size_t>((2 * k + 1) * scale) * 2;
        const std::uint8_t* pair = row + static_cast<std::size_t>(k * scale) * 4;
        o[4 * k] = first[0];
        o[4 * k + 1] = pair[1];
        o[4 * k + 2] = second[0];
        o[4 * k + 3] = pair[3];
      }
    } else {
      for (int u = 0; u < width; ++u) {
        for (int b = 0; b < bytes_per_pixel; ++b)
          o[u * bytes_per_pixel + b] =
              row[static_cast<std::size_t>(u * scale) * bytes_per_pixel + b];
      }
    }
  }
}

PreviewPublisher::PreviewPublisher(bus::Node& node, double rate_hz, bus::BusId bus)
    : node_(node),
      period_us_(rate_hz > 0.0 ? static_cast<Utime>(std::llround(1e6 / rate_hz)) : 0),
      bus_(bus) {}

void PreviewPublisher::onFrame(const image_t& frame) {
  if (period_us_ == 0 || frame.header.utime < next_due_) return;
  next_due_ = frame.header.utime + period_us_;
  try {
    reduceFrame(frame, bus::kCameraPreviewScale, preview_);
  } catch (const std::invalid_argument& e) {
    node_.reportError("preview", e.what());
    return;
  }
  if (node_.publish(bus::channels::kCameraPreview, preview_, bus_)) ++published_;
}

}  // namespace fieldline::camera
