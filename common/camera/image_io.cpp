#include "common/camera/image_io.hpp"

#include <cstdio>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "common/camera/image_header.hpp"

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
  checkImageSize(path);  // before decoding: a decompression bomb is refused unread
  cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  if (image.empty()) throw std::runtime_error("cannot read image " + path);
  return image;
}

FrameSize parseFrameSize(const std::string& text, bool even_width) {
  int w = 0, h = 0, used = 0;
  char x = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%n", &w, &x, &h, &used) != 3 ||
      used != static_cast<int>(text.size()) || x != 'x' || w <= 0 || h <= 0 || w > 16384 ||
      h > 16384) {
    throw std::invalid_argument("expected WIDTHxHEIGHT (e.g. 320x240), got '" + text + "'");
  }
  if (even_width && w % 2 != 0) {
    throw std::invalid_argument("YUYV needs an even width, got '" + text + "'");
  }
  return {w, h};
}

FrameView FrameFile::view() const {
  if (!yuyv.empty()) {
    return {yuyv.data(), size.width, size.height, 2 * size.width, PixelFormat::kYuyv};
  }
  return viewOfBgr(bgr);
}

FrameFile readFrameFile(const std::string& path, const std::optional<FrameSize>& yuyv_size) {
  FrameFile f;
  if (!yuyv_size) {
    f.bgr = readBgrImage(path);
    f.size = {f.bgr.cols, f.bgr.rows};
    return f;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  f.yuyv.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  const std::size_t expected =
      2 * static_cast<std::size_t>(yuyv_size->width) * static_cast<std::size_t>(yuyv_size->height);
  if (f.yuyv.size() != expected) {
    throw std::runtime_error(path + ": " + std::to_string(f.yuyv.size()) + " bytes, expected " +
                             std::to_string(expected) + " for " + std::to_string(yuyv_size->width) +
                             "x" + std::to_string(yuyv_size->height) + " YUYV");
  }
  f.size = *yuyv_size;
  return f;
}

}  // namespace fieldline::camera
