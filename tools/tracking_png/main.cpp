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

cv::Scalar toScalar(camera::Bgr c) {
  return {double(c.b), double(c.g), double(c.r)};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Draws a rendered frame with the region tracker's regions, boundaries and line points."};
  std::string cameraPreset = "omni_sim", fieldPreset = "msl", out = "tracking_frame.png";
  std::string pose = "1.0,0.5,0.3", ball;
  std::vector<std::string> robots;
  int scale = 3, frames = 1;
  bool touched = false;
  double speed = 1.0, omega_deg = 90.0;
  app.add_option("--camera", cameraPreset, "camera preset")->capture_default_str();
  app.add_option("--field", fieldPreset, "field preset")->capture_default_str();
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
  FIELDLINE_PARSE(app, argc, argv);

  return fieldline::bus::runMain("tracking_png", [&]() -> int {
    rt::SimCamera sim = rt::SimCamera::load(cameraPreset, fieldPreset);
    const rt::VisionParams params = rt::defaultVisionParams();
    rt::FrameProcessor processor(sim.mirror, sim.table, params);

    const std::vector<double> p = fieldline::bus::parseNumberList(pose, 3, "--pose");
    camera::SimScene scene;
    if (!ball.empty()) {
      const std::vector<double> b = fieldline::bus::parseNumberList(ball, 2, "--ball");
      scene.ball = camera::SimBall{{b[0], b[1]}, 0.11};
    }
    for (const std::string& r : robots) {
      const std::vector<double> xy = fieldline::bus::parseNumberList(r, 2, "--robot");
      scene.robots.push_back({{xy[0], xy[1]}, 0.25, false});
    }
    // Drive backwards from the pose so the last frame is at --pose, tracked from earlier ones.
    rt::VisionResult result;
    camera::FrameView view;
    const double omega = omega_deg * M_PI / 180.0;
    for (int i = frames - 1; i >= 0; --i) {
      const double t = i / 30.0;
      scene.robot = {p[0] - speed * t * std::cos(p[2]), p[1] - speed * t * std::sin(p[2]),
                     p[2] - omega * t};
      scene.frame_number = static_cast<std::uint64_t>(frames - 1 - i);
      view = sim.render(scene);
      processor.process(view, true, result);
    }

    // The frame as BGR, enlarged.
    cv::Mat image(view.height, view.width, CV_8UC3);
    for (int v = 0; v < view.height; ++v) {
      for (int u = 0; u < view.width; ++u) {
        const camera::Bgr c = camera::readBgr(view, u, v);
        image.at<cv::Vec3b>(v, u) = {c.b, c.g, c.r};
      }
    }
    cv::resize(image, image, {}, scale, scale, cv::INTER_NEAREST);
    // Tracked cells tinted with their class colour.
    const rt::CellGrid& grid = processor.grid();
    cv::Mat tint = image.clone();
    for (int y = 0; y < grid.height; ++y) {
      for (int x = 0; x < grid.width; ++x) {
        const rt::ClassId c = processor.tracker().ownerOf(x, y);
        if (c == rt::kNoClass) continue;
        const int s = grid.cell_size * scale;
        cv::rectangle(tint, {x * s, y * s, s, s},
                      toScalar(camera::displayColour(static_cast<camera::ColourClass>(c))),
                      cv::FILLED);
      }
    }
    cv::addWeighted(tint, 0.35, image, 0.65, 0.0, image);
    if (touched) {
      for (int y = 0; y < grid.height; ++y) {
        for (int x = 0; x < grid.width; ++x) {
          if (!processor.tracker().classifiedInLastFrame(x, y)) continue;
          const int s = grid.cell_size * scale;
          cv::rectangle(image, {x * s + 1, y * s + 1, s - 2, s - 2}, cv::Scalar(255, 0, 255), 1);
        }
      }
    }
    // Boundaries: outer contours in yellow-ish, holes in cyan.
    const rt::ContourSet& contours = processor.tracker().contours();
    for (const rt::Contour& contour : contours.contours) {
      std::vector<cv::Point> polyline;
      for (const rt::ContourPoint& q : contours.pointsOf(contour)) {
        polyline.emplace_back(q.x * scale, q.y * scale);
      }
      cv::polylines(image, polyline, true,
                    contour.outer ? cv::Scalar(0, 220, 255) : cv::Scalar(255, 255, 0), 1);
    }
    // Line points (red), each sequence joined.
    for (const auto& [first, end] : result.lines.sequences) {
      for (int i = first; i < end; ++i) {
        const rt::LinePoint& q = result.lines.points[i];
        const cv::Point centre(static_cast<int>((q.u + 0.5f) * scale),
                               static_cast<int>((q.v + 0.5f) * scale));
        cv::circle(image, centre, 2, cv::Scalar(0, 0, 255), cv::FILLED);
        if (i + 1 < end) {
          const rt::LinePoint& n = result.lines.points[i + 1];
          cv::line(image, centre,
                   {static_cast<int>((n.u + 0.5f) * scale), static_cast<int>((n.v + 0.5f) * scale)},
                   cv::Scalar(0, 0, 200), 1);
        }
      }
    }
    if (result.ball.visible) {
      const cv::Point c(static_cast<int>((result.ball.u + 0.5) * scale),
                        static_cast<int>((result.ball.v + 0.5) * scale));
      cv::drawMarker(image, c, cv::Scalar(255, 0, 255), cv::MARKER_CROSS, 6 * scale, 2);
    }
    const rt::TrackingStats& s = result.tracking;
    const std::string caption = "touched " + std::to_string(int(100 * s.touched_fraction + 0.5)) +
                                "%  overlap " + std::to_string(int(100 * s.overlap + 0.5)) +
                                "%  line points " + std::to_string(result.lines.points.size());
    cv::putText(image, caption, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255),
                1);
    if (!cv::imwrite(out, image)) throw std::runtime_error("cannot write " + out);
    std::cout << "wrote " << out << ": " << caption << ", ball "
              << (result.ball.visible ? "at " + std::to_string(result.ball.x) + "," +
                                            std::to_string(result.ball.y) + " (robot frame)"
                                      : std::string("not seen"))
              << ", obstacles " << result.obstacles.size() << "\n";
    return 0;
  });
}
