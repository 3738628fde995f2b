// Frames as OpenCV images: the bridge between raw camera frames (FrameView) and files.
// Kept out of the core camera library so that code needing only the mirror model and the colour
// table does not link OpenCV.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"

namespace fieldline::camera {

// A view of an 8-bit, 3-channel BGR cv::Mat (no copy). Throws std::invalid_argument for other
// types.
FrameView viewOfBgr(const cv::Mat& bgr);
// The frame as a BGR image (YUYV converted pixel by pixel with bgrFromYuv; BGR copied). For
// files and people, not for the per-frame pipeline. Throws std::invalid_argument for an invalid
// view.
cv::Mat toBgrImage(const FrameView& frame);
// Every pixel replaced by the display colour of its class.
cv::Mat classificationImage(const FrameView& frame, const ColourTable& table);
// Writes an image (format from the extension); throws std::runtime_error on failure.
void writeImage(const std::string& path, const cv::Mat& image);
// Reads a colour image as BGR; throws std::runtime_error if it cannot be read or its header
// declares a size beyond image_header.hpp's limits (checked before decoding).
cv::Mat readBgrImage(const std::string& path);

// Image size "WIDTHxHEIGHT" (e.g. "320x240"); throws std::invalid_argument for anything else,
// and for an odd width when `even_width` (YUYV pairs).
struct FrameSize {
  int width = 0;
  int height = 0;
};
FrameSize parseFrameSize(const std::string& text, bool even_width = true);

// A frame read from a file, owning its pixels: an image file (PNG, JPEG, BMP, anything OpenCV
// reads; grey images become BGR) or raw YUYV 4:2:2 of a given size. Moving keeps view() valid.
struct FrameFile {
  cv::Mat bgr;                     // image files
  std::vector<std::uint8_t> yuyv;  // raw YUYV
  FrameSize size;

  FrameView view() const;
};
// Reads `path` as an image, or as raw YUYV when `yuyv_size` is given (the file must hold exactly
// 2 * width * height bytes). Throws std::runtime_error naming the file otherwise.
FrameFile readFrameFile(const std::string& path, const std::optional<FrameSize>& yuyv_size = {});

}  // namespace fieldline::camera
