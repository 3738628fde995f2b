#include "tools/tracking_png/tracking_png_app.hpp"

#include <fstream>
#include <iostream>
#include <numbers>
#include <stdexcept>

#include "common/bus/cli.hpp"
#include "common/config/config.hpp"
#include "common/perception/line_points_csv.hpp"
#include "tools/tracking_png/tracking_png.hpp"

namespace fieldline::tracking_png {

void AppOptions::addTo(cli::App& app) {
  app.add_option("--camera", camera_preset, "camera preset or path (mirror, colour table)")
      ->capture_default_str();
  app.add_option("--colours", colour_table, "colour table preset or path (default: the camera's)");
  app.add_option("--vision-config", vision_config,
                 "vision YAML as fieldline-region-tracking reads it (default: built-in)");
  app.add_option("--in", in,
                 "frame file: PNG, JPEG, BMP (any size with the camera's aspect ratio), or raw "
                 "YUYV with --yuyv; without it a simulated frame is rendered");
  app.add_option("--yuyv", yuyv_size, "--in is raw YUYV 4:2:2 of this size, e.g. 320x240");
  app.add_option("--repeat", repeat, "track a file this many times (regions settle)")
      ->check(cli::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--field", field_preset, "field preset (rendering)")->capture_default_str();
  app.add_option("--pose", pose, "rendered robot pose x,y,phi (m, m, rad), field frame")
      ->capture_default_str();
  app.add_option("--ball", ball, "rendered ball at x,y (m), field frame");
  app.add_option("--robot", robots, "rendered robot at x,y (m), field frame (repeatable)");
  app.add_option("--frames", frames,
                 "render and track a drive of this many frames ending at --pose")
      ->check(cli::Range(1, 10000))
      ->capture_default_str();
  app.add_option("--speed", speed, "speed of that drive, m/s")->capture_default_str();
  app.add_option("--omega", omega_deg, "rotation of that drive, deg/s")->capture_default_str();
  app.add_option("--out", out, "output PNG")->capture_default_str();
  app.add_option("--csv", csv,
                 "write the line points here: x,y in the robot frame (m), a blank line between "
                 "sequences (fieldline-features --points, fieldline-localize)");
  app.add_option("--json", json, "write line points (image u,v and robot x,y), ball, obstacles");
  app.add_option("--scale", scale, "output pixels per image pixel")
      ->check(cli::Range(1, 8))
      ->capture_default_str();
  app.add_flag("--touched", touched, "mark the cells the tracker classified in the last frame");
}

namespace {

std::ofstream openOut(const std::string& path) {
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cannot write " + path);
  return file;
}

}  // namespace

void runApp(const AppOptions& o) {
  region_tracking::VisionParams vision = region_tracking::defaultVisionParams();
  if (!o.vision_config.empty()) {
    vision = region_tracking::loadVisionParams(config::Node::loadFile(o.vision_config));
  }
  std::unique_ptr<TrackedFrame> tracked;
  if (!o.in.empty()) {
    FileRequest request{o.in, std::nullopt, o.repeat};
    if (!o.yuyv_size.empty()) request.yuyv_size = camera::parseFrameSize(o.yuyv_size);
    tracked = trackFile(o.camera_preset, o.colour_table, vision, request);
  } else {
    if (!o.yuyv_size.empty()) throw std::invalid_argument("--yuyv needs --in");
    RenderRequest request;
    request.field_preset = o.field_preset;
    request.pose = bus::parseNumberList(o.pose, 3, "--pose");
    if (!o.ball.empty()) {
      const std::vector<double> b = bus::parseNumberList(o.ball, 2, "--ball");
      request.ball = std::array<double, 2>{b[0], b[1]};
    }
    for (const std::string& r : o.robots) {
      const std::vector<double> xy = bus::parseNumberList(r, 2, "--robot");
      request.robots.push_back({xy[0], xy[1]});
    }
    request.frames = o.frames;
    request.speed = o.speed;
    request.omega = o.omega_deg * std::numbers::pi / 180.0;
    tracked = trackRendered(o.camera_preset, o.colour_table, vision, request);
  }
  camera::writeImage(o.out, drawTracking(*tracked, o.scale, o.touched));
  if (!o.csv.empty()) {
    std::ofstream file = openOut(o.csv);
    perception::writeLinePointsCsv(file, tracked->result.lines);
    if (!file) throw std::runtime_error("cannot write " + o.csv);
  }
  if (!o.json.empty()) {
    std::ofstream file = openOut(o.json);
    writeDetectionsJson(file, *tracked);
    if (!file) throw std::runtime_error("cannot write " + o.json);
  }
  std::cout << "wrote " << o.out << ": " << summary(*tracked) << "\n";
}

}  // namespace fieldline::tracking_png
