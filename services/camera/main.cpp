// fieldline-camera: one robot's camera. Publishes CAMERA_IMAGE on the robot's bus from
//   --source sim        rendered from SIM_WORLD (simulator bus) at the preset's frame rate
//   --source v4l2       a V4L2 camera (--input /dev/video0), raw YUYV unless --bgr
//   --source video      a video file (--input clip.avi)
//   --source gstreamer  a GStreamer pipeline ending in appsink (--input "...")
//   --source folder     PNG/JPEG/BMP files of a folder in name order (--input dir)
//   --source log        CAMERA_IMAGE frames of an LCM log (--input file.lcmlog)
// utime is the exposure time: the render tick for sim, receive time - latency for cameras and
// files. A log keeps its recorded exposure times (--keep-stamps, the default; --restamp to
// stamp like a camera): the process then runs on a clock at the log's time and publishes each
// frame when its time comes. A log goes onto robot N's replay bus (port base + 100 + N,
// --replay-bus-url) so it never mixes with the live frames, unless --live-bus is given.
#include <algorithm>
#include <memory>
#include <optional>
#include <string>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/replay_bus.hpp"
#include "common/config/config.hpp"
#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/camera_node.hpp"
#include "services/camera/log_source.hpp"
#include "services/camera/sources.hpp"

namespace camera = fieldline::camera;
namespace bus = fieldline::bus;

namespace {

// Seconds between attempts to (re)open a live camera.
constexpr double kReopenIntervalS = 1.0;

int runLiveSource(bus::Node& node, camera::SourceKind kind, const camera::VideoCaptureOptions& vc,
                  const camera::CameraConfig& config, const camera::FrameSourceOptions& options) {
  bus::installStopSignals();
  while (!node.stopRequested()) {
    try {
      auto source = camera::openVideoCapture(kind, vc);
      spdlog::info("publishing {} (latency {} ms)", source->describe(),
                   config.pipeline.latency * 1e3);
      node.status().setFault(false);
      const std::int64_t frames = camera::runFrameSource(node, *source, config.pipeline, options);
      node.status().setFault(true);
      if (node.stopRequested() || (options.max_frames > 0 && frames >= options.max_frames)) break;
      node.reportError(
          "camera_lost",
          vc.spec + " stopped delivering frames" +
              (source->lastError().empty() ? std::string() : ": " + source->lastError()));
    } catch (const std::runtime_error& e) {
      node.status().setFault(true);
      node.reportError("camera_open", e.what());
    }
    // Keep status and timers alive while waiting to retry.
    const fieldline::Utime retry_at =
        node.now() + static_cast<fieldline::Utime>(kReopenIntervalS * 1e6);
    while (!node.stopRequested() && node.now() < retry_at)
      node.spinOnce(50);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Camera of one robot: publishes CAMERA_IMAGE (simulated or real source)"};
  bus::CommonOptions common;
  common.addTo(app);
  std::string source_name = "sim";
  std::string preset = "omni_sim";
  std::string field;
  std::string input;
  double latency = -1.0;
  double fps = 0.0;
  int width = 0;
  int height = 0;
  bool loop = false;
  bool bgr = false;
  std::int64_t max_frames = 0;
  bool keep_stamps = true;
  bool restamp = false;
  bool live_bus = false;
  std::string replay_bus_url;
  app.add_option("--source", source_name, "Frame source")
      ->check(CLI::IsMember({"sim", "v4l2", "video", "gstreamer", "folder", "log"}))
      ->capture_default_str();
  app.add_option("--config", preset, "Camera preset (config/camera/<name>.yaml) or path")
      ->capture_default_str();
  app.add_option("--field", field,
                 "sim: field preset to render (default: the field SIM_WORLD names)");
  app.add_option("--input", input,
                 "v4l2 device or index, video file, GStreamer pipeline, image folder or LCM log");
  app.add_option("--latency", latency, "Exposure-to-delivery latency, s (default: the preset's)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--fps", fps,
                 "Frame rate: v4l2 request, pace of folder/video/log (default: the preset's)")
      ->check(CLI::Range(0.0, 240.0));
  app.add_option("--width", width, "v4l2: requested width, px")->check(CLI::Range(0, 8192));
  app.add_option("--height", height, "v4l2: requested height, px")->check(CLI::Range(0, 8192));
  app.add_flag("--loop", loop, "folder/video/log: start again at the end");
  app.add_flag("--bgr", bgr, "v4l2: take OpenCV's BGR frames instead of raw YUYV");
  app.add_option("--max-frames", max_frames,
                 "Real sources: stop after this many frames (0: no limit)");
  auto* keep = app.add_flag("--keep-stamps", keep_stamps,
                            "log: keep the logged exposure times (the default)");
  app.add_flag("--restamp", restamp,
               "log: stamp frames receive time - latency like a camera's, paced by --fps")
      ->excludes(keep);
  app.add_flag("--live-bus", live_bus,
               "log: publish on --bus-url (the live bus) instead of the robot's replay bus");
  app.add_option("--replay-bus-url", replay_bus_url,
                 "log: the bus the frames go to (default: robot N's replay bus, "
                 "udpm://239.255.76.67:<7767+N>?ttl=0...)");
  FIELDLINE_PARSE(app, argc, argv);
  common.resolve("camera");
  const bool from_log = source_name == "log";
  if (from_log && !live_bus) {
    common.bus_url =
        replay_bus_url.empty() ? bus::replayBusUrl(std::max(1, common.robot)) : replay_bus_url;
  }

  return bus::runMain("camera", [&]() -> int {
    camera::CameraConfig config = camera::loadCameraConfigPreset(preset);
    if (latency >= 0.0) config.pipeline.latency = latency;
    if (fps > 0.0) config.pipeline.frame_rate = fps;
    if (source_name != "sim" && input.empty()) {
      throw fieldline::config::Error("--source " + source_name + " needs --input");
    }
    if (common.check_args) return 0;
    fieldline::SystemClock system_clock;
    // A log with kept stamps runs at the log's time: its first frame is due now.
    std::optional<fieldline::OffsetClock> log_clock;
    if (from_log && !restamp) {
      if (const auto first = camera::LogImageSource::firstUtime(input)) {
        const auto latency_us = static_cast<fieldline::Utime>(config.pipeline.latency * 1e6);
        log_clock.emplace(system_clock, *first + latency_us - system_clock.now(), 0.0, 0);
      }
    }
    const fieldline::Clock& clock =
        log_clock ? static_cast<const fieldline::Clock&>(*log_clock) : system_clock;
    bus::Node node({.process = "camera", .robot_id = common.robot, .url = common.bus_url}, clock);

    if (source_name == "sim") {
      const bus::BusId sim_bus = node.addBus(common.sim_bus_url);
      camera::SimCameraNode sim(node, sim_bus, config, field);
      spdlog::info("rendering {}x{} at {} Hz, latency {} ms, from SIM_WORLD on {}",
                   config.model.mirror.width(), config.model.mirror.height(),
                   config.pipeline.frame_rate, config.pipeline.latency * 1e3, common.sim_bus_url);
      return node.run();
    }

    std::unique_ptr<camera::FrameSource> source;
    camera::FrameSourceOptions options;
    options.max_frames = max_frames;
    if (source_name == "folder") {
      source = std::make_unique<camera::ImageFolderSource>(input, loop);
      options.pace_fps = config.pipeline.frame_rate;
    } else if (source_name == "log") {
      source = std::make_unique<camera::LogImageSource>(input, loop);
      options.keep_stamps = !restamp;
      options.pace_fps = restamp ? config.pipeline.frame_rate : 0.0;
      spdlog::info("replaying {} onto {}{}", input, common.bus_url,
                   restamp ? ", restamped" : " with its exposure times");
    } else {
      camera::VideoCaptureOptions vc;
      vc.spec = input;
      vc.width = width;
      vc.height = height;
      vc.fps = fps;
      vc.raw_yuyv = !bgr;
      vc.loop = loop;
      const camera::SourceKind kind = source_name == "v4l2"    ? camera::SourceKind::kV4l2
                                      : source_name == "video" ? camera::SourceKind::kVideo
                                                               : camera::SourceKind::kGstreamer;
      if (kind != camera::SourceKind::kVideo) {
        // A live camera that is missing or unplugged comes back: report it (SERVICE_STATUS keeps
        // flowing) and reopen it, as the motor bridge does with its serial line.
        return runLiveSource(node, kind, vc, config, options);
      }
      source = camera::openVideoCapture(kind, vc);
      // Files play at the configured rate.
      options.pace_fps = config.pipeline.frame_rate;
    }
    spdlog::info("publishing {} (latency {} ms)", source->describe(),
                 config.pipeline.latency * 1e3);
    bus::installStopSignals();
    const std::int64_t frames = camera::runFrameSource(node, *source, config.pipeline, options);
    spdlog::info("{} frames published, {} unusable", frames, source->errors());
    if (frames == 0 && !source->lastError().empty()) {
      throw std::runtime_error("no frame published: " + source->lastError());
    }
    return 0;
  });
}
