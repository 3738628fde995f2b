// Issue 13 finding 9: `fieldline-camera --source log` re-stamped the logged frames (now - 60 ms),
// so a replayed log lost its exposure times. Now a log's frames keep their logged stamps (the
// default, --keep-stamps), published on a clock that runs at the log's time, and a looped log
// keeps its stamps increasing; --restamp gives the camera-like stamps. Log replay goes to a bus
// of its own (robot N's replay bus) unless --live-bus.
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/bus/replay_bus.hpp"
#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"
#include "services/camera/camera_node.hpp"
#include "services/camera/log_source.hpp"

namespace fieldline::camera {
namespace health_camera_test {

// A recorded afternoon: frames 10 ms apart, long before now.
constexpr Utime kLogStart = 1'600'000'000'000'000;
constexpr Utime kFramePeriod = 10'000;

std::string writeLog(int frames) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("fieldline_health_camera_" + std::to_string(::getpid()) + ".lcmlog"))
                               .string();
  bus::LogWriter log(path);
  for (int k = 0; k < frames; ++k) {
    image_t img{};
    img.header.robot_id = 1;
    img.header.seq = k;
    img.header.utime = kLogStart + k * kFramePeriod;
    img.header.utime_published = img.header.utime + 60'000;
    img.width = 4;
    img.height = 2;
    img.stride = 8;
    img.format = image_t::FORMAT_YUYV;
    img.source = image_t::SOURCE_V4L2;
    img.frame_number = k;
    img.size = 16;
    img.data.assign(16, static_cast<std::uint8_t>(k));
    log.write(bus::channels::kCameraImage, img.header.utime_published, img);
  }
  return path;
}

// Publishes the log through runFrameSource; returns the received CAMERA_IMAGE stamps.
std::vector<Utime> replay(const Clock& clock, LogImageSource& source, bool keep_stamps,
                          std::int64_t max_frames) {
  const auto memq = bus::Connection::open("memq://");
  bus::Node camera{{.process = "camera", .robot_id = 1, .status_period_us = 0}, clock, memq};
  bus::Node harness{{.process = "harness", .robot_id = 0, .status_period_us = 0}, clock, memq};
  std::vector<Utime> stamps;
  harness.subscribe(bus::channels::kCameraImage,
                    [&](const image_t& img) { stamps.push_back(img.header.utime); });
  PipelineParams pipeline;
  pipeline.latency = 0.060;
  FrameSourceOptions options;
  options.keep_stamps = keep_stamps;
  options.max_frames = max_frames;
  options.pace_fps = keep_stamps ? 0.0 : 1000.0;
  runFrameSource(camera, source, pipeline, options);
  for (int i = 0; i < 10; ++i)
    harness.spinOnce(0);
  return stamps;
}

TEST(HealthCamera, LogReplayKeepsTheLoggedExposureTimes) {
  const std::string path = writeLog(5);
  ASSERT_EQ(LogImageSource::firstUtime(path), kLogStart);
  SystemClock system;
  // What fieldline-camera does with a log: its clock runs at the log's time.
  OffsetClock log_clock(system, kLogStart + 60'000 - system.now(), 0.0, 0);
  LogImageSource source(path, false);
  const std::vector<Utime> stamps = replay(log_clock, source, true, 0);
  ASSERT_EQ(stamps.size(), 5U);
  for (int k = 0; k < 5; ++k)
    EXPECT_EQ(stamps[k], kLogStart + k * kFramePeriod) << k;  // before: now - 60 ms

  // --restamp: stamped like a camera's frames, on the receiver's clock.
  LogImageSource again(path, false);
  const Utime before = system.now();
  const std::vector<Utime> restamped = replay(system, again, false, 0);
  ASSERT_EQ(restamped.size(), 5U);
  for (Utime t : restamped) {
    EXPECT_GE(t, before - 60'000);
    EXPECT_LE(t, system.now());
  }
  std::filesystem::remove(path);
}

TEST(HealthCamera, ALoopedLogKeepsItsStampsIncreasing) {
  const std::string path = writeLog(3);
  SystemClock system;
  OffsetClock log_clock(system, kLogStart + 60'000 - system.now(), 0.0, 0);
  LogImageSource source(path, true);
  const std::vector<Utime> stamps = replay(log_clock, source, true, 7);
  ASSERT_EQ(stamps.size(), 7U);
  for (std::size_t k = 0; k < stamps.size(); ++k)
    EXPECT_EQ(stamps[k], kLogStart + static_cast<Utime>(k) * kFramePeriod) << k;
  std::filesystem::remove(path);
}

TEST(HealthCamera, ReplayGoesToABusOfItsOwn) {
  for (int robot = 1; robot <= 6; ++robot) {
    EXPECT_NE(bus::replayBusUrl(robot), bus::robotBusUrl(robot));
    EXPECT_NE(bus::replayBusUrl(robot).find(":" + std::to_string(7767 + robot) + "?"),
              std::string::npos)
        << bus::replayBusUrl(robot);
    for (int other = 1; other <= 6; ++other)
      EXPECT_NE(bus::replayBusUrl(robot), bus::robotBusUrl(other));
  }
  EXPECT_NE(bus::replayBusUrl(1), bus::simBusUrl());
}

}  // namespace health_camera_test
}  // namespace fieldline::camera
