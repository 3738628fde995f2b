// fieldline-tracking-png: renders a simulated camera frame (or a sequence, drawing the last
// frame), runs the region tracker and its detectors on it, and writes a PNG with the tracked
// regions tinted, their boundaries, the line points and the ball and obstacle detections.
//
//   fieldline-tracking-png --pose 1.0,0.5,0.3 --ball 2.0,1.2 --robot 3,-1
//                          --out docs/images/tracking_frame.png
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/bus/cli.hpp"
#include "common/config/config.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tests/support/sim_frames.hpp"

namespace rt = fieldline::region_tracking;
namespace camera = fieldline::camera;

namespace {

struct Options {
  std::string camera_preset = "omni_sim", field_preset = "msl", out = "tracking_frame.png";
  std::string pose = "1.0,0.5,0.3", ball;
  std::vector<std::string> robots;
  int scale = 3, frames = 1;
  bool touched = false;
  double speed = 1.0, omega_deg = 90.0;

  void addTo(CLI::App& app) {
    app.add_option("--camera", camera_preset, "camera preset")->capture_default_str();
    app.add_option("--field", field_preset, "field preset")->capture_default_str();
    app.add_option("--pose", pose, "robot pose x,y,phi (m, m, rad), field frame")
        ->capture_default_str();
    app.add_option("--ball", ball, "ball position x,y (m), field frame");
    app.add_option("--robot", robots, "another robot at x,y (m), field frame (repeatable)");
    app.add_option("--frames", frames, "track this many frames of a drive ending at --pose first")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    app.add_option("--speed", speed, "speed of that drive, m/s")->capture_default_str();
    app.add_option("--omega", omega_deg, "rotation of that drive, deg/s")->capture_default_str();
    app.add_option("--scale", scale, "output pixels per image pixel")
        ->check(CLI::Range(1, 8))
        ->capture_default_str();
    app.add_option("--out", out, "output PNG")->capture_default_str();
    app.add_flag("--touched", touched, "mark the cells the tracker classified in the last frame");
  }
};

cv::Scalar toScalar(camera::Bgr c) {
  return {double(c.b), double(c.g), double(c.r)};
}

// Renders a drive that ends at --pose (driving backwards from it, so the last frame is at the
// pose and was tracked from the earlier ones) and processes every frame; `view` is the last one.
rt::VisionResult trackDrive(const Options& options, rt::SimCamera& sim,
                            rt::FrameProcessor& processor, camera::FrameView& view) {
  const std::vector<double> p = fieldline::bus::parseNumberList(options.pose, 3, "--pose");
  camera::SimScene scene;
  if (!options.ball.empty()) {
    const std::vector<double> b = fieldline::bus::parseNumberList(options.ball, 2, "--ball");
    scene.ball = camera::SimBall{{b[0], b[1]}, 0.11};
  }
  for (const std::string& r : options.robots) {
    const std::vector<double> xy = fieldline::bus::parseNumberList(r, 2, "--robot");
    scene.robots.push_back({{xy[0], xy[1]}, 0.25, false});
  }
  rt::VisionResult result;
  const double omega = options.omega_deg * M_PI / 180.0;
  const double speed = options.speed;
  for (int i = options.frames - 1; i >= 0; --i) {
    const double t = i / 30.0;
    scene.robot = {p[0] - speed * t * std::cos(p[2]), p[1] - speed * t * std::sin(p[2]),
                   p[2] - omega * t};
    scene.frame_number = static_cast<std::uint64_t>(options.frames - 1 - i);
    view = sim.render(scene);
    processor.process(view, true, result);
  }
  return result;
}

// The frame as BGR, enlarged, with the tracked cells tinted in their class colour and (with
// --touched) the cells classified in the last frame marked.
cv::Mat drawCells(const Options& options, const camera::FrameView& view,
                  const rt::FrameProcessor& processor) {
  const int scale = options.scale;
  cv::Mat image(view.height, view.width, CV_8UC3);
  for (int v = 0; v < view.height; ++v) {
    for (int u = 0; u < view.width; ++u) {
      const camera::Bgr c = camera::readBgr(view, u, v);
      image.at<cv::Vec3b>(v, u) = {c.b, c.g, c.r};
    }
  }
  cv::resize(image, image, {}, scale, scale, cv::INTER_NEAREST);
  const rt::CellGrid& grid = processor.grid();
  const int s = grid.cell_size * scale;
  cv::Mat tint = image.clone();
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const rt::ClassId c = processor.tracker().ownerOf(x, y);
      if (c == rt::kNoClass) continue;
      cv::rectangle(tint, {x * s, y * s, s, s},
                    toScalar(camera::displayColour(static_cast<camera::ColourClass>(c))),
                    cv::FILLED);
    }
  }
  cv::addWeighted(tint, 0.35, image, 0.65, 0.0, image);
  if (!options.touched) return image;
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      if (!processor.tracker().classifiedInLastFrame(x, y)) continue;
      cv::rectangle(image, {x * s + 1, y * s + 1, s - 2, s - 2}, cv::Scalar(255, 0, 255), 1);
    }
  }
  return image;
}

// Boundaries (outer contours yellow-ish, holes cyan), line points (red, each sequence joined),
// the ball (magenta cross).
void drawDetections(int scale, const rt::ContourSet& contours, const rt::VisionResult& result,
                    cv::Mat& image) {
  for (const rt::Contour& contour : contours.contours) {
    std::vector<cv::Point> polyline;
    for (const rt::ContourPoint& q : contours.pointsOf(contour)) {
      polyline.emplace_back(q.x * scale, q.y * scale);
    }
    cv::polylines(image, polyline, true,
                  contour.outer ? cv::Scalar(0, 220, 255) : cv::Scalar(255, 255, 0), 1);
  }
  auto at = [scale](const rt::LinePoint& q) {
    return cv::Point(static_cast<int>((q.u + 0.5f) * scale),
                     static_cast<int>((q.v + 0.5f) * scale));
  };
  for (const auto& [first, end] : result.lines.sequences) {
    for (int i = first; i < end; ++i) {
      cv::circle(image, at(result.lines.points[i]), 2, cv::Scalar(0, 0, 255), cv::FILLED);
      if (i + 1 < end) {
        cv::line(image, at(result.lines.points[i]), at(result.lines.points[i + 1]),
                 cv::Scalar(0, 0, 200), 1);
      }
    }
  }
  if (result.ball.visible) {
    const cv::Point c(static_cast<int>((result.ball.u + 0.5) * scale),
                      static_cast<int>((result.ball.v + 0.5) * scale));
    cv::drawMarker(image, c, cv::Scalar(255, 0, 255), cv::MARKER_CROSS, 6 * scale, 2);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Draws a rendered frame with the region tracker's regions, boundaries and line points."};
  Options options;
  options.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);

  return fieldline::bus::runMain("tracking_png", [&]() -> int {
    rt::SimCamera sim = rt::SimCamera::load(options.camera_preset, options.field_preset);
    rt::FrameProcessor processor(sim.mirror, sim.table, rt::defaultVisionParams());
    camera::FrameView view;
    const rt::VisionResult result = trackDrive(options, sim, processor, view);
    cv::Mat image = drawCells(options, view, processor);
    drawDetections(options.scale, processor.tracker().contours(), result, image);

    const rt::TrackingStats& s = result.tracking;
    const std::string caption = "touched " + std::to_string(int(100 * s.touched_fraction + 0.5)) +
                                "%  overlap " + std::to_string(int(100 * s.overlap + 0.5)) +
                                "%  line points " + std::to_string(result.lines.points.size());
    cv::putText(image, caption, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255),
                1);
    if (!cv::imwrite(options.out, image)) throw std::runtime_error("cannot write " + options.out);
    std::cout << "wrote " << options.out << ": " << caption << ", ball "
              << (result.ball.visible ? "at " + std::to_string(result.ball.x) + "," +
                                            std::to_string(result.ball.y) + " (robot frame)"
                                      : std::string("not seen"))
              << ", obstacles " << result.obstacles.size() << "\n";
    return 0;
  });
}
