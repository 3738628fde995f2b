// CAMERA_PREVIEW (services/camera/camera_preview_node.hpp): the frame at a quarter of its size,
// pixel for pixel from the full frame, with its exposure time; at most the configured rate, on the
// bus it is given.
#include <gtest/gtest.h>

#include <vector>

#include "common/bus/node.hpp"
#include "common/time/clock.hpp"
#include "services/camera/camera_preview_node.hpp"

namespace fieldline::camera {
namespace camera_preview_test {

image_t yuyvFrame(Utime utime, int width, int height) {
  image_t m{};
  m.header.utime = utime;
  m.width = width;
  m.height = height;
  m.stride = 2 * width;
  m.format = image_t::FORMAT_YUYV;
  m.frame_number = 17;
  m.exposure_us = 8000;
  m.size = m.stride * height;
  m.data.resize(static_cast<std::size_t>(m.size));
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * m.stride + 2 * u;
      m.data[i] = static_cast<std::uint8_t>(u + v);  // Y: column + row
      m.data[i + 1] = static_cast<std::uint8_t>(u % 2 == 0 ? 100 + u / 2 : 200 + u / 2);  // U, V
    }
  }
  return m;
}

TEST(CameraPreview, EveryFourthPixelOfEveryFourthRowKeepingItsChroma) {
  const image_t full = yuyvFrame(1'000'000, 64, 48);
  image_t preview;
  reduceFrame(full, 4, preview);
  EXPECT_EQ(preview.width, 16);
  EXPECT_EQ(preview.height, 12);
  EXPECT_EQ(preview.stride, 32);
  EXPECT_EQ(preview.size, 32 * 12);
  EXPECT_EQ(preview.format, image_t::FORMAT_YUYV);
  EXPECT_EQ(preview.header.utime, full.header.utime);
  EXPECT_EQ(preview.frame_number, 17);
  EXPECT_EQ(preview.exposure_us, 8000);
  for (int v = 0; v < 12; ++v) {
    for (int u = 0; u < 16; ++u) {
      const std::uint8_t* p = preview.data.data() + v * 32 + 2 * u;
      EXPECT_EQ(p[0], 4 * u + 4 * v) << u << "," << v;  // Y of full pixel (4u, 4v)
    }
    for (int k = 0; k < 8; ++k) {
      // The pair's chroma: that of full pair 4k (pixels 8k, 8k + 1).
      const std::uint8_t* p = preview.data.data() + v * 32 + 4 * k;
      EXPECT_EQ(p[1], 100 + 4 * k);
      EXPECT_EQ(p[3], 200 + 4 * k);
    }
  }
}

TEST(CameraPreview, BgrAndGreyAndBadFrames) {
  image_t bgr{};
  bgr.header.utime = 1'000'000;
  bgr.width = 8;
  bgr.height = 4;
  bgr.stride = 24;
  bgr.format = image_t::FORMAT_BGR;
  bgr.size = 96;
  bgr.data.resize(96);
  for (std::size_t i = 0; i < bgr.data.size(); ++i)
    bgr.data[i] = static_cast<std::uint8_t>(i);
  image_t out;
  reduceFrame(bgr, 4, out);
  ASSERT_EQ(out.width, 2);
  ASSERT_EQ(out.height, 1);
  EXPECT_EQ(out.data, (std::vector<std::uint8_t>{0, 1, 2, 12, 13, 14}));
  image_t small = yuyvFrame(1'000'000, 4, 4);
  EXPECT_THROW(reduceFrame(small, 4, out), std::invalid_argument);  // nothing left
  image_t cut = yuyvFrame(1'000'000, 64, 48);
  cut.data.resize(100);
  EXPECT_THROW(reduceFrame(cut, 4, out), std::invalid_argument);
  cut.data.resize(static_cast<std::size_t>(cut.size));
  cut.format = 9;
  EXPECT_THROW(reduceFrame(cut, 4, out), std::invalid_argument);
}

TEST(CameraPreview, AtMostTheRateOnTheBusItIsGiven) {
  SimulatedClock clock;
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera{{.process = "camera", .robot_id = 1, .status_period_us = 0}, clock, memq};
  bus::Node viewer{{.process = "viewer", .robot_id = 0, .status_period_us = 0}, clock, memq};
  std::vector<image_t> previews;
  int full_frames = 0;
  viewer.subscribe(bus::channels::kCameraPreview, [&](const image_t& m) { previews.push_back(m); });
  viewer.subscribe(bus::channels::kCameraImage, [&](const image_t&) { ++full_frames; });
  PreviewPublisher preview(camera, 2.0);
  // 3 s of a 30 Hz camera: six previews, each with its frame's exposure time.
  for (int k = 0; k < 90; ++k) {
    clock.advance(33'333);
    image_t frame = yuyvFrame(clock.now(), 64, 48);
    preview.onFrame(frame);
    camera.spinOnce(0);
    viewer.spinOnce(0);
  }
  EXPECT_EQ(full_frames, 0);  // only the preview goes out here
  ASSERT_EQ(previews.size(), 6u);
  EXPECT_EQ(preview.published(), 6);
  for (std::size_t i = 1; i < previews.size(); ++i) {
    EXPECT_GE(previews[i].header.utime - previews[i - 1].header.utime, 500'000);
    EXPECT_LE(previews[i].header.utime - previews[i - 1].header.utime, 533'334);
  }
  EXPECT_EQ(previews[0].width, 16);
  PreviewPublisher off(camera, 0.0);
  off.onFrame(yuyvFrame(clock.now(), 64, 48));
  EXPECT_EQ(off.published(), 0);
}

}  // namespace camera_preview_test
}  // namespace fieldline::camera
