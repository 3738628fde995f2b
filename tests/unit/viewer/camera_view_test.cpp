// The viewer's camera view: the selected robot's frame as a JPEG with the VISION_LINES and
// VISION_BALL of that very frame, at most max_rate_hz, other robots' frames ignored.
#include "tools/viewer/camera_view.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace fieldline::viewer {
namespace camera_view_test {

constexpr Utime kT0 = 1'700'000'000'000'000;

// A YUYV frame: left half dark, right half bright, neutral chroma.
image_t frame(Utime utime, int width = 64, int height = 48) {
  image_t m{};
  m.header.utime = utime;
  m.header.seq = utime % 1000;
  m.width = width;
  m.height = height;
  m.stride = 2 * width;
  m.format = image_t::FORMAT_YUYV;
  m.frame_number = utime / 1000;
  m.size = m.stride * height;
  m.data.resize(static_cast<std::size_t>(m.size));
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * m.stride + 2 * u;
      m.data[i] = u < width / 2 ? 40 : 200;
      m.data[i + 1] = 128;
    }
  }
  return m;
}

line_contours_t lines(Utime utime, int points) {
  line_contours_t m{};
  m.header.utime = utime;
  m.header.seq = 7;
  m.num_points = points;
  for (int i = 0; i < points; ++i) {
    m.u.push_back(10.0f + i);
    m.v.push_back(20.5f);
    m.x.push_back(1.0f);
    m.y.push_back(0.0f);
  }
  m.num_sequences = 1;
  m.sequence_start = {0};
  m.sequence_end = {points};
  return m;
}

std::string between(const std::string& text, const std::string& from, const std::string& to) {
  const auto a = text.find(from);
  if (a == std::string::npos) return {};
  const auto b = text.find(to, a + from.size());
  return text.substr(a + from.size(), b - a - from.size());
}

std::vector<std::uint8_t> unbase64(const std::string& text) {
  const std::string digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<std::uint8_t> out;
  std::uint32_t bits = 0;
  int count = 0;
  for (char c : text) {
    if (c == '=') break;
    bits = (bits << 6) | static_cast<std::uint32_t>(digits.find(c));
    count += 6;
    if (count >= 8) {
      count -= 8;
      out.push_back(static_cast<std::uint8_t>((bits >> count) & 0xff));
    }
  }
  return out;
}

TEST(CameraView, FrameWithItsLinesAndBallAsJpeg) {
  CameraView view;
  view.select(2);
  view.onImage(3, frame(kT0));  // another robot's: ignored
  view.onImage(2, frame(kT0 + 33'000));
  view.onImage(2, frame(kT0 + 66'000));
  view.onLines(2, lines(kT0 + 33'000, 5), kT0 + 70'000);
  ball_observation_t ball{};
  ball.header.utime = kT0 + 33'000;
  ball.visible = true;
  ball.u = 12.5f;
  ball.v = 30.0f;
  view.onBall(2, ball);
  const auto doc = view.update(kT0 + 100'000);
  ASSERT_TRUE(doc);
  EXPECT_EQ(between(*doc, "\"robot\":", ","), "2");
  // The frame the lines were found in, not the newest one.
  EXPECT_EQ(between(*doc, "\"frame\":{\"utime\":", ","), std::to_string(kT0 + 33'000));
  EXPECT_NE(doc->find("\"lines\":{\"utime\":" + std::to_string(kT0 + 33'000)), std::string::npos);
  EXPECT_NE(doc->find("\"num_points\":5,\"u\":[10,11,12,13,14],\"v\":[20.5,"), std::string::npos)
      << *doc;
  EXPECT_NE(doc->find("\"sequences\":[[0,5]]"), std::string::npos);
  EXPECT_NE(doc->find("\"ball\":{\"utime\":" + std::to_string(kT0 + 33'000) +
                      ",\"seq\":0,\"visible\":true,\"u\":12.5,\"v\":30}"),
            std::string::npos)
      << *doc;

  const std::vector<std::uint8_t> jpeg = unbase64(between(*doc, "\"jpeg\":\"", "\""));
  EXPECT_EQ(between(*doc, "\"jpeg_bytes\":", ","), std::to_string(jpeg.size()));
  const cv::Mat image = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  ASSERT_EQ(image.cols, 64);
  ASSERT_EQ(image.rows, 48);
  // Dark left, bright right, grey (YUV 40 / 200 with neutral chroma).
  const cv::Vec3b left = image.at<cv::Vec3b>(24, 8), right = image.at<cv::Vec3b>(24, 56);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(left[c], 29, 8);  // BT.601 limited range: (40 - 16) * 255 / 219
    EXPECT_NEAR(right[c], 214, 8);
  }
  EXPECT_EQ(view.framesEncoded(), 1);
}

TEST(CameraView, AtMostTheRateAndOnlyNewFrames) {
  CameraView view({.max_rate_hz = 5.0});
  view.select(1);
  view.onImage(1, frame(kT0));
  view.onLines(1, lines(kT0, 3), kT0);
  ASSERT_TRUE(view.update(kT0 + 10'000));
  EXPECT_FALSE(view.update(kT0 + 20'000));  // nothing new
  view.onImage(1, frame(kT0 + 100'000));
  view.onLines(1, lines(kT0 + 100'000, 3), kT0 + 100'000);
  EXPECT_FALSE(view.update(kT0 + 150'000));  // new, but 140 ms after the last one
  const auto doc = view.update(kT0 + 210'000);
  ASSERT_TRUE(doc);
  EXPECT_EQ(between(*doc, "\"frame\":{\"utime\":", ","), std::to_string(kT0 + 100'000));
  EXPECT_FALSE(view.update(kT0 + 500'000));  // the same frame is not sent twice
}

TEST(CameraView, WaitsForLinesButShowsFramesWhenTheTrackerIsSilent) {
  CameraView view({.lines_missing_after_us = kMicrosPerSecond});
  view.select(4);
  view.onLines(4, lines(kT0 - 1'000'000, 2), kT0);  // for a frame never received
  view.onImage(4, frame(kT0 + 10'000));
  EXPECT_FALSE(view.update(kT0 + 20'000));        // lines came recently: wait for this frame's
  const auto doc = view.update(kT0 + 1'100'000);  // silent for over 1 s: the frame alone
  ASSERT_TRUE(doc);
  EXPECT_NE(doc->find("\"lines\":null,\"ball\":null"), std::string::npos) << *doc;

  // Never any lines (no tracker at all): frames at once.
  CameraView bare;
  bare.select(5);
  bare.onImage(5, frame(kT0));
  EXPECT_TRUE(bare.update(kT0));
}

TEST(CameraView, AnotherRobotForgetsWhatWasKeptAndNoneShowsNothing) {
  CameraView view;
  view.select(1);
  view.onImage(1, frame(kT0));
  view.select(2);
  EXPECT_FALSE(view.update(kT0 + 1'000'000));
  view.onImage(2, frame(kT0 + 5'000));
  EXPECT_TRUE(view.update(kT0 + 1'000'000));
  view.select(0);
  view.onImage(0, frame(kT0 + 10'000));
  EXPECT_FALSE(view.update(kT0 + 3'000'000));
}

TEST(CameraView, FramesThatDoNotFitTheirDataAreRefusedAndCounted) {
  CameraView view;
  view.select(1);
  image_t bad = frame(kT0);
  bad.data.resize(100);
  view.onImage(1, bad);
  EXPECT_FALSE(view.update(kT0));
  EXPECT_EQ(view.framesRefused(), 1);
  EXPECT_NE(view.lastProblem(), "");
  image_t unknown = frame(kT0 + 1);
  unknown.format = 9;
  EXPECT_THROW(encodeJpeg(unknown, 80), std::invalid_argument);
  image_t grey = frame(kT0 + 2);
  grey.format = image_t::FORMAT_GRAY;
  grey.stride = grey.width;
  EXPECT_FALSE(encodeJpeg(grey, 80).empty());
  EXPECT_THROW(CameraView({.max_rate_hz = 0.0}), std::invalid_argument);
}

TEST(CameraView, APreviewFromAnotherMachineIsDrawnAtTheCamerasSizeWithItsLines) {
  CameraView view({.max_rate_hz = 30.0});
  view.select(1);
  // Only CAMERA_PREVIEW arrives (a 16x12 copy of a 64x48 camera's frame); the tracker's lines of
  // that frame and of later ones it does not get.
  view.onPreview(1, frame(kT0, 16, 12));
  view.onLines(1, lines(kT0 - 33'000, 2), kT0);
  EXPECT_FALSE(view.update(kT0 + 10'000));  // its lines may still come
  view.onLines(1, lines(kT0, 4), kT0 + 20'000);
  auto doc = view.update(kT0 + 30'000);
  ASSERT_TRUE(doc);
  EXPECT_NE(doc->find("\"stream\":\"preview\",\"width\":64,\"height\":48,\"image_width\":16,"
                      "\"image_height\":12"),
            std::string::npos)
      << *doc;
  EXPECT_NE(doc->find("\"lines\":{\"utime\":" + std::to_string(kT0)), std::string::npos);
  const cv::Mat image =
      cv::imdecode(unbase64(between(*doc, "\"jpeg\":\"", "\"")), cv::IMREAD_COLOR);
  EXPECT_EQ(image.cols, 16);
  EXPECT_EQ(image.rows, 12);
  // A later preview whose lines went by (newer lines came, none of them its own): shown alone.
  view.onPreview(1, frame(kT0 + 500'000, 16, 12));
  view.onLines(1, lines(kT0 + 533'000, 3), kT0 + 540'000);
  doc = view.update(kT0 + 550'000);
  ASSERT_TRUE(doc);
  EXPECT_EQ(between(*doc, "\"frame\":{\"utime\":", ","), std::to_string(kT0 + 500'000));
  EXPECT_NE(doc->find("\"lines\":null"), std::string::npos);
  // Full frames (the viewer on the robot's machine) win over previews of the same time.
  view.onImage(1, frame(kT0 + 600'000));
  view.onPreview(1, frame(kT0 + 600'000, 16, 12));
  view.onLines(1, lines(kT0 + 600'000, 3), kT0 + 610'000);
  doc = view.update(kT0 + 620'000);
  ASSERT_TRUE(doc);
  EXPECT_NE(doc->find("\"stream\":\"full\",\"width\":64,\"height\":48,\"image_width\":64"),
            std::string::npos)
      << *doc;
}

TEST(Base64, Rfc4648Vectors) {
  auto b = [](const std::string& s) {
    return base64(std::vector<std::uint8_t>(s.begin(), s.end()));
  };
  EXPECT_EQ(b(""), "");
  EXPECT_EQ(b("f"), "Zg==");
  EXPECT_EQ(b("fo"), "Zm8=");
  EXPECT_EQ(b("foo"), "Zm9v");
  EXPECT_EQ(b("foob"), "Zm9vYg==");
  EXPECT_EQ(b("fooba"), "Zm9vYmE=");
  EXPECT_EQ(b("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64({0xff, 0xfe, 0x00}), "//4A");
}

}  // namespace camera_view_test
}  // namespace fieldline::viewer
