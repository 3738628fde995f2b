// Camera frames travel on a bus of their own (frames_bus.hpp): the URL arithmetic, and over udpm
// that a node routes CAMERA_IMAGE there by itself while the rest stays on the robot bus.
#include <unistd.h>

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/frames_bus.hpp"
#include "common/bus/node.hpp"

namespace fieldline::bus {
namespace {

TEST(FramesBus, UdpmUrlsMoveByTheOffsetAndKeepTheirOptions) {
  EXPECT_TRUE(travelsOnFramesBus(channels::kCameraImage.name));
  EXPECT_FALSE(travelsOnFramesBus(channels::kCameraPreview.name));
  EXPECT_FALSE(travelsOnFramesBus(channels::kOdometry.name));
  EXPECT_EQ(framesBusUrl(robotBusUrl(1)), "udpm://239.255.76.67:7868?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(framesBusUrl(robotBusUrl(6, {.ttl = 1})),
            "udpm://239.255.76.67:7873?ttl=1&recv_buf_size=4194304");
  EXPECT_EQ(framesBusUrl("udpm://239.255.76.67:7668"), "udpm://239.255.76.67:7868");
  // LCM's default port when none is named.
  EXPECT_EQ(framesBusUrl("udpm://239.255.76.67?ttl=0"), "udpm://239.255.76.67:7867?ttl=0");
  // Frames share the bus where there is no port to move.
  EXPECT_EQ(framesBusUrl("memq://"), "memq://");
  EXPECT_EQ(framesBusUrl("udpm://239.255.76.67:65500"), "udpm://239.255.76.67:65500");
  EXPECT_EQ(framesBusUrl("udpm://239.255.76.67:x?ttl=0"), "udpm://239.255.76.67:x?ttl=0");
}

image_t smallImage(Utime utime) {
  image_t img{};
  img.header.utime = utime;
  img.width = 4;
  img.height = 2;
  img.stride = 8;
  img.format = image_t::FORMAT_YUYV;
  img.source = image_t::SOURCE_SIM;
  img.size = 16;
  img.data.assign(16, 128);
  return img;
}

TEST(FramesBus, NodesRouteFramesToTheirOwnBusOverUdpm) {
  // A port of its own so runs in parallel (and other processes on this host) do not mix.
  const int port = 20000 + static_cast<int>(getpid() % 20000);
  const std::string url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
  SystemClock clock;
  std::shared_ptr<Connection> bus;
  try {
    bus = Connection::open(url);
  } catch (const BusError& e) {
    GTEST_SKIP() << "no multicast route here: " << e.what();
  }
  Node camera({.process = "camera", .robot_id = 1, .status_period_us = 0}, clock, bus);
  Node tracker({.process = "tracker", .robot_id = 1, .url = url, .status_period_us = 0}, clock);
  // Listens on the frames bus's port as if it were a robot bus: it hears only the frames.
  Node frames_port(
      {.process = "probe", .robot_id = 1, .url = framesBusUrl(url), .status_period_us = 0}, clock);
  std::vector<std::string> on_frames_port;
  // LCM's own self test at start-up aside.
  const auto keep = [](const std::string& channel) { return channel != "LCM_SELF_TEST"; };
  frames_port.subscribeAllRaw([&](const std::string& channel, const void*, int) {
    if (keep(channel)) on_frames_port.push_back(channel);
  });
  int images = 0;
  int odometry = 0;
  tracker.subscribe(channels::kCameraImage, [&](const image_t& m) {
    EXPECT_EQ(m.width, 4);
    ++images;
  });
  tracker.subscribe(channels::kOdometry, [&](const odometry_t&) { ++odometry; });
  // A recorder listening to everything on the robot bus still gets both.
  std::vector<std::string> recorded;
  Node recorder({.process = "recorder", .robot_id = 1, .url = url, .status_period_us = 0}, clock);
  recorder.subscribeAllRaw([&](const std::string& channel, const void*, int) {
    if (keep(channel)) recorded.push_back(channel);
  });

  image_t img = smallImage(clock.now());
  ASSERT_TRUE(camera.publish(channels::kCameraImage, img));
  odometry_t odo{};
  odo.header.utime = clock.now();
  ASSERT_TRUE(camera.publish(channels::kOdometry, odo));
  for (int i = 0;
       i < 50 && (images == 0 || odometry == 0 || recorded.size() < 2 || on_frames_port.empty());
       ++i) {
    tracker.spinOnce(20);
    recorder.spinOnce(0);
    frames_port.spinOnce(0);
  }
  EXPECT_EQ(images, 1);
  EXPECT_EQ(odometry, 1);
  EXPECT_EQ(on_frames_port, std::vector<std::string>{"CAMERA_IMAGE"});
  ASSERT_EQ(recorded.size(), 2u);
  EXPECT_EQ(tracker.status().takeStatus(clock.now()).num_errors, 0);
}

}  // namespace
}  // namespace fieldline::bus
