#include "common/camera/image_io.hpp"

#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace fieldline::camera {

FrameView viewOfBgr(const cv::Mat& bgr) {
  if (bgr.type() != CV_8UC3 || bgr.empty()) {
    throw std::invalid_argument("viewOfBgr: expected a non-empty 8-bit 3-channel image");
  }
  return {bgr.data, bgr.cols, bgr.rows, static_cast<int>(bgr.step[0]), PixelFormat::kBgr};
}

cv::Mat toBgrImage(const FrameView& frame) {
  if (!frame.valid()) throw std::invalid_argument("toBgrImage: invalid frame view");
  cv::Mat out(frame.height, frame.width, CV_8UC3);
  for (int v = 0; v < frame.height; ++v) {
    auto* row = out.ptr<cv::Vec3b>(v);
    for (int u = 0; u < frame.width; ++u) {
      const Bgr c = readBgr(frame, u, v);
      row[u] = {c.b, c.g, c.r};
    }
  }
  return out;
}

cv::Mat classificationImage(const FrameView& frame, const ColourTable& table) {
  if (!frame.valid()) throw std::invalid_argument("classificationImage: invalid frame view");
  cv::Mat out(frame.height, frame.width, CV_8UC3);
  for (int v = 0; v < frame.height; ++v) {
    auto* row = out.ptr<cv::Vec3b>(v);
    for (int u = 0; u < frame.width; ++u) {
      const Bgr c = displayColour(table.classifyPixel(frame, u, v));
      row[u] = {c.b, c.g, c.r};
    }
  }
  return out;
}

void writeImage(const std::string& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write " + path + ": " + e.what());
  }
  if (!ok) throw std::runtime_error("cannot write " + path);
}

cv::Mat readBgrImage(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  if (image.empty()) throw std::runtime_error("cannot read image " + path);
  return image;
}

}  // namespace fieldline::camera
