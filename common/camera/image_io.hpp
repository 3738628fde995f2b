// Frames as OpenCV images: the bridge between raw camera frames (FrameView) and files.
// Kept out of the core camera library so that code needing only the mirror model and the colour
// table does not link OpenCV.
#pragma once

#include <string>

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
// Reads a colour image as BGR; throws std::runtime_error if it cannot be read.
cv::Mat readBgrImage(const std::string& path);

}  // namespace fieldline::camera
