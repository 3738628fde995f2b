// A read-only view of one raw camera frame in the layout the sensor delivered, so that the
// vision code reads single pixels where it needs them instead of converting whole frames.
//
// Pixel coordinates: column u to the right, row v down, origin at the top-left pixel; integer
// coordinates are pixel centres (the OpenCV convention).
//
// Colour space: 8-bit full-range YCbCr after ITU-R BT.601 (the JPEG/JFIF form), written Y, U
// (= Cb), V (= Cr). yuvFromBgr / bgrFromYuv convert single pixels between that and 8-bit BGR;
// the simulated camera renders with the same formulas, so a table tuned on rendered YUYV frames
// classifies the same scene given as BGR.
#pragma once

#include <algorithm>
#include <cstdint>

namespace fieldline::camera {

enum class PixelFormat : std::uint8_t {
  // YUYV 4:2:2: four bytes Y0 U Y1 V per pair of pixels; both pixels of a pair share U and V.
  kYuyv,
  // Three bytes B G R per pixel (OpenCV's native order).
  kBgr,
};

struct Yuv {
  std::uint8_t y = 0;
  std::uint8_t u = 128;
  std::uint8_t v = 128;
};
// The renderer's YUYV packing reads pixels as packed 3-byte runs (sim_renderer.cpp).
static_assert(sizeof(Yuv) == 3 && alignof(Yuv) == 1);

struct Bgr {
  std::uint8_t b = 0;
  std::uint8_t g = 0;
  std::uint8_t r = 0;
};

namespace detail {
inline std::uint8_t clampToByte(float value) {
  return static_cast<std::uint8_t>(std::clamp(value + 0.5f, 0.0f, 255.0f));
}
}  // namespace detail

// Full-range BT.601: Y = 0.299 R + 0.587 G + 0.114 B, U = 128 + 0.564 (B - Y),
// V = 128 + 0.713 (R - Y).
inline Yuv yuvFromBgr(Bgr c) {
  const float y = 0.299f * c.r + 0.587f * c.g + 0.114f * c.b;
  return {detail::clampToByte(y), detail::clampToByte(128.0f + 0.564f * (c.b - y)),
          detail::clampToByte(128.0f + 0.713f * (c.r - y))};
}

inline Bgr bgrFromYuv(Yuv c) {
  const float u = c.u - 128.0f;
  const float v = c.v - 128.0f;
  return {detail::clampToByte(c.y + 1.772f * u), detail::clampToByte(c.y - 0.344f * u - 0.714f * v),
          detail::clampToByte(c.y + 1.402f * v)};
}

// A frame in memory owned by someone else (an LCM message, a cv::Mat, a renderer buffer).
// `stride` is the number of bytes from the start of one row to the start of the next. For YUYV
// the width must be even.
struct FrameView {
  const std::uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  int stride = 0;
  PixelFormat format = PixelFormat::kYuyv;

  bool contains(int u, int v) const { return u >= 0 && v >= 0 && u < width && v < height; }
  // Smallest stride that holds one row of `width` pixels in `format`.
  static int minStride(int width, PixelFormat format) {
    return format == PixelFormat::kYuyv ? 2 * width : 3 * width;
  }
  // True if the view describes a usable frame (non-null data, positive size, even YUYV width,
  // stride large enough).
  bool valid() const {
    return data != nullptr && width > 0 && height > 0 &&
           (format != PixelFormat::kYuyv || width % 2 == 0) && stride >= minStride(width, format);
  }
};

// One pixel as YUV, read in place. The caller keeps (u, v) inside the frame (no check here: this
// runs once per pixel in the trackers; FrameView::contains tests it).
inline Yuv readYuv(const FrameView& frame, int u, int v) {
  const std::uint8_t* row = frame.data + static_cast<std::ptrdiff_t>(v) * frame.stride;
  if (frame.format == PixelFormat::kYuyv) {
    const std::uint8_t* pair = row + static_cast<std::ptrdiff_t>(u >> 1) * 4;
    return {pair[(u & 1) * 2], pair[1], pair[3]};
  }
  const std::uint8_t* px = row + static_cast<std::ptrdiff_t>(u) * 3;
  return yuvFromBgr({px[0], px[1], px[2]});
}

// One pixel as BGR, read in place (YUYV pixels are converted, one pixel only).
inline Bgr readBgr(const FrameView& frame, int u, int v) {
  const std::uint8_t* row = frame.data + static_cast<std::ptrdiff_t>(v) * frame.stride;
  if (frame.format == PixelFormat::kBgr) {
    const std::uint8_t* px = row + static_cast<std::ptrdiff_t>(u) * 3;
    return {px[0], px[1], px[2]};
  }
  return bgrFromYuv(readYuv(frame, u, v));
}

}  // namespace fieldline::camera
