// fieldline-camera-snapshot: writes a camera frame to a PNG for a person to look at.
//
//   fieldline-camera-snapshot --robot 3 --out r3.png          # robot 3's next CAMERA_IMAGE
//   fieldline-camera-snapshot --robot 3 --out r3.png --classes # its colour classification
//   fieldline-camera-snapshot --render 1.0,-0.5,0.2 --field msl --ball 2,0 --obstacle 3,1
//       --out view.png
//                                                             # rendered offline, no bus
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <opencv2/core.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/camera/colour.hpp"
#include "common/camera/image_io.hpp"
#include "common/cli/cli.hpp"
#include "common/field/field_model.hpp"
#include "common/msg/image.hpp"
#include "common/time/clock.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/camera_node.hpp"
#include "services/camera/sim_renderer.hpp"

namespace cli = fieldline::cli;
namespace camera = fieldline::camera;
namespace bus = fieldline::bus;
namespace msg = fieldline::msg;

namespace {

void writeFrame(const camera::FrameView& view, const std::string& out, bool classes,
                const std::string& colour_table) {
  cv::Mat image = camera::toBgrImage(view);
  if (classes) {
    cv::hconcat(image,
                camera::classificationImage(view, camera::loadColourTablePreset(colour_table)),
                image);
  }
  camera::writeImage(out, image);
}

struct Options {
  std::string out;
  std::string preset = "omni_sim";
  std::string render_pose;
  std::string field = "msl";
  std::string ball;
  std::vector<std::string> obstacles;
  bool classes = false;
  double timeout = 5.0;

  void addTo(cli::App& app) {
    app.add_option("--out", out, "PNG file to write")->required();
    app.add_flag("--classes", classes, "Add the colour classification to the right of the frame");
    app.add_option("--timeout", timeout, "Seconds to wait for a frame")->capture_default_str();
    app.add_option("--config", preset, "Camera preset (colour table; offline: mirror and scene)")
        ->capture_default_str();
    app.add_option("--render", render_pose,
                   "Render offline from field pose x,y,phi (m, m, rad) instead of the bus");
    app.add_option("--field", field, "Offline: field preset")->capture_default_str();
    app.add_option("--ball", ball, "Offline: ball at field x,y (m)");
    app.add_option("--obstacle", obstacles,
                   "Offline: an opponent robot at field x,y (m); repeatable");
  }
};

// --render: the scene drawn by the simulator's renderer, no bus.
int renderOffline(const Options& options, const camera::CameraConfig& config) {
  const std::vector<double> p = bus::parseNumberList(options.render_pose, 3, "--render");
  camera::SimRenderer renderer(config.model.mirror,
                               fieldline::field::loadFieldPreset(options.field),
                               camera::renderParamsOf(config, "--render"));
  camera::SimScene scene;
  scene.robot = {p[0], p[1], p[2]};
  if (!options.ball.empty()) {
    const std::vector<double> b = bus::parseNumberList(options.ball, 2, "--ball");
    scene.ball = camera::SimBall{{b[0], b[1]}, 0.11};
  }
  for (const std::string& o : options.obstacles) {
    const std::vector<double> xy = bus::parseNumberList(o, 2, "--obstacle");
    scene.robots.push_back({{xy[0], xy[1]}, 0.25, false});
  }
  std::vector<std::uint8_t> frame;
  renderer.render(scene, frame);
  writeFrame(renderer.view(frame), options.out, options.classes, config.model.colour_table);
  std::printf("wrote %s (rendered at %.2f, %.2f, %.2f on %s)\n", options.out.c_str(), p[0], p[1],
              p[2], options.field.c_str());
  return 0;
}

// The robot's next CAMERA_IMAGE, waited for at most --timeout seconds.
int snapshotFromBus(const Options& options, const camera::CameraConfig& config,
                    const bus::CommonOptions& common) {
  fieldline::SystemClock clock;
  bus::Node node({.process = "camera-snapshot",
                  .robot_id = common.robot,
                  .url = common.bus_url,
                  .status_period_us = 0},
                 clock);
  std::optional<fieldline::image_t> image;
  node.subscribe(bus::channels::kCameraImage, [&](const fieldline::image_t& m) {
    if (!image) image = m;
  });
  const fieldline::Utime deadline =
      clock.now() + static_cast<fieldline::Utime>(options.timeout * fieldline::kMicrosPerSecond);
  while (!image && clock.now() < deadline && !node.stopRequested())
    node.spinOnce(100);
  if (!image) {
    std::fprintf(stderr, "camera-snapshot: no CAMERA_IMAGE on %s within %.1f s\n",
                 common.bus_url.c_str(), options.timeout);
    return 1;
  }
  const std::optional<camera::FrameView> view = msg::fromMessage(*image);
  if (!view) {
    std::fprintf(stderr, "camera-snapshot: image format %d cannot be shown\n", image->format);
    return 1;
  }
  writeFrame(*view, options.out, options.classes, config.model.colour_table);
  std::printf("wrote %s: robot %d frame %lld, %dx%d, latency %.1f ms\n", options.out.c_str(),
              common.robot, static_cast<long long>(image->frame_number), image->width,
              image->height,
              static_cast<double>(image->header.utime_published - image->header.utime) / 1e3);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{"Write a robot's current camera frame (or an offline rendering) to a PNG"};
  bus::CommonOptions common;
  common.addTo(app);
  Options options;
  options.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);
  common.resolve("camera-snapshot");

  return bus::runMain("camera-snapshot", [&]() -> int {
    const camera::CameraConfig config = camera::loadCameraConfigPreset(options.preset);
    if (!options.render_pose.empty()) return renderOffline(options, config);
    return snapshotFromBus(options, config, common);
  });
}
