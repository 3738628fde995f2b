#include "tools/tracking_png/tracking_png.hpp"

#include <cmath>
#include <ostream>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "common/config/config.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::tracking_png {
namespace rt = region_tracking;

namespace {

cv::Scalar toScalar(camera::Bgr c) {
  return {double(c.b), double(c.g), double(c.r)};
}

std::unique_ptr<TrackedFrame> prepare(camera::MirrorModel mirror, const std::string& colour_table,
                                      const rt::VisionParams& vision) {
  auto tracked = std::make_unique<TrackedFrame>();
  tracked->mirror = std::move(mirror);
  tracked->table = camera::loadColourTablePreset(colour_table);
  tracked->processor =
      std::make_unique<rt::FrameProcessor>(tracked->mirror, tracked->table, vision);
  return tracked;
}

// The camera's mirror for a frame of `size`: as configured, or scaled to it.
camera::MirrorModel mirrorFor(const camera::MirrorModel& mirror, camera::FrameSize size,
                              const std::string& what) {
  if (size.width == mirror.width() && size.height == mirror.height()) return mirror;
  try {
    return mirror.scaledTo(size.width, size.height);
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument(fmt::format(
        "{} is {}x{}, the camera is {}x{} (another aspect ratio): give the camera config of the "
        "robot that took it (--camera)",
        what, size.width, size.height, mirror.width(), mirror.height()));
  }
}

}  // namespace

std::unique_ptr<TrackedFrame> trackFile(const std::string& camera_preset,
                                        const std::string& colour_table,
                                        const rt::VisionParams& vision,
                                        const FileRequest& request) {
  if (request.repeat < 1) throw std::invalid_argument("repeat must be at least 1");
  const camera::CameraModel model = camera::loadCameraPreset(camera_preset);
  camera::FrameFile file = camera::readFrameFile(request.path, request.yuyv_size);
  auto tracked = prepare(mirrorFor(model.mirror, file.size, request.path),
                         colour_table.empty() ? model.colour_table : colour_table, vision);
  tracked->file = std::move(file);
  tracked->view = tracked->file.view();
  for (int i = 0; i < request.repeat; ++i) {
    tracked->processor->process(tracked->view, true, tracked->result);
  }
  return tracked;
}

std::unique_ptr<TrackedFrame> trackRendered(const std::string& camera_preset,
                                            const std::string& colour_table,
                                            const rt::VisionParams& vision,
                                            const RenderRequest& request) {
  if (request.pose.size() != 3) throw std::invalid_argument("the pose needs x, y and phi");
  if (request.frames < 1) throw std::invalid_argument("frames must be at least 1");
  rt::SimCamera sim = rt::SimCamera::load(camera_preset, request.field_preset);
  auto tracked = prepare(
      sim.mirror,
      colour_table.empty() ? camera::loadCameraPreset(camera_preset).colour_table : colour_table,
      vision);
  camera::SimScene scene;
  if (request.ball) scene.ball = camera::SimBall{{(*request.ball)[0], (*request.ball)[1]}, 0.11};
  for (const auto& r : request.robots)
    scene.robots.push_back({{r[0], r[1]}, 0.25, false});
  const std::vector<double>& p = request.pose;
  for (int i = request.frames - 1; i >= 0; --i) {
    const double t = i / 30.0;
    scene.robot = {p[0] - request.speed * t * std::cos(p[2]),
                   p[1] - request.speed * t * std::sin(p[2]), p[2] - request.omega * t};
    scene.frame_number = static_cast<std::uint64_t>(request.frames - 1 - i);
    sim.render(scene);
    tracked->rendered = sim.frame;
    tracked->view = sim.renderer->view(tracked->rendered);
    tracked->processor->process(tracked->view, true, tracked->result);
  }
  return tracked;
}

cv::Mat drawTracking(const TrackedFrame& tracked, int scale, bool touched) {
  if (scale < 1) throw std::invalid_argument("scale must be at least 1");
  const rt::FrameProcessor& processor = *tracked.processor;
  cv::Mat image;
  cv::resize(camera::toBgrImage(tracked.view), image, {}, scale, scale, cv::INTER_NEAREST);
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
  for (int y = 0; touched && y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      if (!processor.tracker().classifiedInLastFrame(x, y)) continue;
      cv::rectangle(image, {x * s + 1, y * s + 1, s - 2, s - 2}, cv::Scalar(255, 0, 255), 1);
    }
  }
  // The mirror's zones (self reflection, useful radius, edge): on a real frame they show whether
  // the camera config fits the picture.
  const camera::MirrorParams& mp = tracked.mirror.params();
  const cv::Point centre(static_cast<int>((mp.centre.x() + 0.5) * scale),
                         static_cast<int>((mp.centre.y() + 0.5) * scale));
  for (const double r : {mp.self_radius, mp.useful_radius, mp.outer_radius}) {
    cv::circle(image, centre, static_cast<int>(r * scale), cv::Scalar(200, 120, 0), 1);
  }
  const rt::ContourSet& contours = processor.tracker().contours();
  for (const rt::Contour& contour : contours.contours) {
    std::vector<cv::Point> polyline;
    for (const rt::ContourPoint& q : contours.pointsOf(contour)) {
      polyline.emplace_back(q.x * scale, q.y * scale);
    }
    cv::polylines(image, polyline, true,
                  contour.outer ? cv::Scalar(0, 220, 255) : cv::Scalar(255, 255, 0), 1);
  }
  auto at = [scale](double u, double v) {
    return cv::Point(static_cast<int>((u + 0.5) * scale), static_cast<int>((v + 0.5) * scale));
  };
  const rt::VisionResult& result = tracked.result;
  for (const auto& [first, end] : result.lines.sequences) {
    for (int i = first; i < end; ++i) {
      const perception::LinePoint& q = result.lines.points[i];
      cv::circle(image, at(q.u, q.v), 2, cv::Scalar(0, 0, 255), cv::FILLED);
      if (i + 1 < end) {
        const perception::LinePoint& n = result.lines.points[i + 1];
        cv::line(image, at(q.u, q.v), at(n.u, n.v), cv::Scalar(0, 0, 200), 1);
      }
    }
  }
  if (result.ball.visible) {
    cv::drawMarker(image, at(result.ball.u, result.ball.v), cv::Scalar(255, 0, 255),
                   cv::MARKER_CROSS, 6 * scale, 2);
  }
  for (const rt::Obstacle& o : result.obstacles) {
    const std::optional<camera::Vec2> px = tracked.mirror.robotToImage(camera::Vec2(o.x, o.y));
    if (!px) continue;
    cv::circle(image, at(px->x(), px->y()), 4 * scale, cv::Scalar(255, 255, 255), 2);
    cv::circle(image, at(px->x(), px->y()), 4 * scale - 2, cv::Scalar(0, 0, 0), 1);
  }
  cv::putText(image, summary(tracked), {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(255, 255, 255), 1);
  return image;
}

std::string summary(const TrackedFrame& tracked) {
  const rt::VisionResult& r = tracked.result;
  return fmt::format(
      "touched {:.0f}%  overlap {:.0f}%  line points {}  ball {}  obstacles {}",
      100 * r.tracking.touched_fraction, 100 * r.tracking.overlap, r.lines.points.size(),
      r.ball.visible ? fmt::format("{:.2f},{:.2f}", r.ball.x, r.ball.y) : std::string("-"),
      r.obstacles.size());
}

void writeDetectionsJson(std::ostream& out, const TrackedFrame& tracked) {
  const rt::VisionResult& r = tracked.result;
  out << fmt::format("{{\"width\":{},\"height\":{},\"line_sequences\":[", tracked.view.width,
                     tracked.view.height);
  for (std::size_t s = 0; s < r.lines.sequences.size(); ++s) {
    const auto [first, end] = r.lines.sequences[s];
    out << (s ? ",[" : "[");
    for (int i = first; i < end; ++i) {
      const perception::LinePoint& q = r.lines.points[i];
      out << fmt::format("{}{{\"u\":{:.2f},\"v\":{:.2f},\"x\":{:.4f},\"y\":{:.4f}}}",
                         i > first ? "," : "", q.u, q.v, q.x, q.y);
    }
    out << "]";
  }
  out << "],\"ball\":";
  if (r.ball.visible) {
    out << fmt::format("{{\"u\":{:.2f},\"v\":{:.2f},\"x\":{:.4f},\"y\":{:.4f},\"pixels\":{}}}",
                       r.ball.u, r.ball.v, r.ball.x, r.ball.y, r.ball.pixels);
  } else {
    out << "null";
  }
  out << ",\"obstacles\":[";
  for (std::size_t i = 0; i < r.obstacles.size(); ++i) {
    const rt::Obstacle& o = r.obstacles[i];
    out << fmt::format(
        "{}{{\"bearing\":{:.4f},\"distance\":{:.4f},\"width\":{:.4f},\"x\":{:.4f},\"y\":{:.4f}}}",
        i ? "," : "", o.bearing, o.distance, o.width, o.x, o.y);
  }
  out << "]}\n";
}

}  // namespace fieldline::tracking_png
