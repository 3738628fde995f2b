#include "services/camera/camera_app.hpp"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include <spdlog/spdlog.h>

#include "common/bus/node.hpp"
#include "common/bus/replay_bus.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/bus/urls.hpp"
#include "common/config/config.hpp"
#include "common/device/device_check.hpp"
#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/camera_node.hpp"
#include "services/camera/camera_preview_node.hpp"
#include "services/camera/floor_raster_cache.hpp"
#include "services/camera/log_source.hpp"
#include "services/camera/sources.hpp"
#include "services/camera/sources_y4m.hpp"

namespace fieldline::camera {

namespace {

// Seconds between attempts to (re)open a live camera.
constexpr double kReopenIntervalS = 1.0;

// A live camera that is missing or unplugged comes back: report it (SERVICE_STATUS keeps flowing)
// and reopen it, as the motor bridge does with its serial line.
int runLiveSource(bus::Node& node, SourceKind kind, const VideoCaptureOptions& vc,
                  const CameraConfig& config, const FrameSourceOptions& options) {
  while (!node.stopRequested()) {
    try {
      auto source = openVideoCapture(kind, vc);
      spdlog::info("publishing {} (latency {} ms)", source->describe(),
                   config.pipeline.latency * 1e3);
      node.status().setFault(false);
      const std::int64_t frames = runFrameSource(node, *source, config.pipeline, options);
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
    const Utime retry_at = node.now() + static_cast<Utime>(kReopenIntervalS * 1e6);
    while (!node.stopRequested() && node.now() < retry_at)
      node.spinOnce(50);
  }
  return 0;
}

// The rendered frames into a named pipe, as a camera delivers them to its driver; the status
// says when nobody reads them or the reader falls behind.
class PipeDelivery {
 public:
  PipeDelivery(bus::Node& node, const std::string& path, int width, int height, double fps)
      : node_(node), writer_(path, width, height, fps) {}

  void operator()(const image_t& frame) {
    using Result = Y4mPipeWriter::Result;
    const Result r = writer_.write(frame.data.data(), frame.stride);
    if (r == Result::kWritten) {
      node_.status().setWarning("pipe", "");
      node_.setMetric("frames_to_pipe", static_cast<double>(++written_));
      return;
    }
    node_.setMetric("frames_dropped", static_cast<double>(++dropped_));
    node_.status().setWarning(
        "pipe", r == Result::kNoReader ? "nobody reads " + writer_.path() + ": frames dropped"
                : r == Result::kReaderBehind
                    ? "the reader of " + writer_.path() + " falls behind: frames dropped"
                    : "the reader of " + writer_.path() + " went away");
  }

 private:
  bus::Node& node_;
  Y4mPipeWriter writer_;
  std::int64_t written_ = 0;
  std::int64_t dropped_ = 0;
};

// The bus CAMERA_IMAGE goes to: the node's own, or, when that one has a ttl (a robot watched
// from another machine), a ttl=0 copy of it, so that 18 MB/s of frames stay on the robot.
bus::BusId framesBus(bus::Node& node, const std::string& bus_url) {
  const std::string local = bus::localOnlyUrl(bus_url);
  if (local == bus_url) return bus::kPrimaryBus;
  spdlog::info(
      "CAMERA_IMAGE stays on this machine ({}); CAMERA_PREVIEW and the status go out "
      "on {}",
      local, bus_url);
  return node.addBus(local);
}

int runSim(bus::Node& node, const CameraConfig& config, const CameraAppOptions& options,
           const bus::CommonOptions& common, bus::BusId frames_bus, PreviewPublisher& preview) {
  const bus::BusId sim_bus = node.addBus(common.sim_bus_url);
  SimCameraNode sim(node, sim_bus, config, options.field, options.raster_cache);
  node.declareIo(cameraIo(options));
  sim.publishOn(frames_bus, &preview);
  std::optional<PipeDelivery> pipe;
  if (!options.to_pipe.empty()) {
    pipe.emplace(node, options.to_pipe, config.model.mirror.width(), config.model.mirror.height(),
                 config.pipeline.frame_rate);
    sim.deliverTo([&pipe](const image_t& frame) { (*pipe)(frame); });
    spdlog::info("frames go into the named pipe {} (YUV4MPEG2), not onto the bus", options.to_pipe);
  }
  spdlog::info("rendering {}x{} at {} Hz, latency {} ms, from SIM_WORLD on {}",
               config.model.mirror.width(), config.model.mirror.height(),
               config.pipeline.frame_rate, config.pipeline.latency * 1e3, common.sim_bus_url);
  return node.run();
}

SourceKind videoSourceKind(const std::string& name) {
  if (name == "v4l2") return SourceKind::kV4l2;
  if (name == "video") return SourceKind::kVideo;
  if (name == "gstreamer") return SourceKind::kGstreamer;
  throw std::runtime_error("unknown camera source '" + name + "'");
}

// What keeps the source from opening, for --check-args: "" when it can (a GStreamer pipeline and
// the simulator are not checked here).
std::string sourceProblem(const CameraAppOptions& options) {
  if (!options.to_pipe.empty() && std::filesystem::exists(options.to_pipe) &&
      !isNamedPipe(options.to_pipe)) {
    return options.to_pipe + ": exists and is not a named pipe (--to-pipe)";
  }
  if (options.source == "v4l2") return device::checkCamera(options.input);
  if (options.source == "folder")
    return device::checkInputFile(options.input, "image folder", true);
  if (options.source == "log") return device::checkInputFile(options.input, "log file", false);
  if (options.source == "video") {
    // A named pipe carries YUV4MPEG2 frames as they come.
    if (isNamedPipe(options.input)) return "";
    return device::checkInputFile(options.input, "video file", false);
  }
  return "";
}

}  // namespace

void CameraAppOptions::addTo(cli::App& app) {
  app.add_option("--source", source, "Frame source")
      ->check(cli::IsMember({"sim", "v4l2", "video", "gstreamer", "folder", "log"}))
      ->capture_default_str();
  app.add_option("--config", preset, "Camera preset (config/camera/<name>.yaml) or path")
      ->capture_default_str();
  app.add_option("--field", field,
                 "sim: field preset to render (default: the field SIM_WORLD names)");
  app.add_option("--input", input,
                 "v4l2 device or index, video file, GStreamer pipeline, image folder or LCM log");
  app.add_option("--latency", latency, "Exposure-to-delivery latency, s (default: the preset's)")
      ->check(cli::Range(0.0, 1.0));
  app.add_option("--fps", fps,
                 "Frame rate: v4l2 request, pace of folder/video/log (default: the preset's)")
      ->check(cli::Range(0.0, 240.0));
  app.add_option("--width", width, "v4l2: requested width, px")->check(cli::Range(0, 8192));
  app.add_option("--height", height, "v4l2: requested height, px")->check(cli::Range(0, 8192));
  app.add_flag("--loop", loop, "folder/video/log: start again at the end");
  app.add_flag("--bgr", bgr, "v4l2: take OpenCV's BGR frames instead of raw YUYV");
  app.add_option("--to-pipe", to_pipe,
                 "sim: write the frames into this named pipe as YUV4MPEG2 (made if missing), "
                 "each at exposure + latency as a camera delivers it, instead of publishing "
                 "CAMERA_IMAGE: a stand-in camera device for a real robot's launch");
  app.add_option("--preview-rate", preview_rate,
                 "CAMERA_PREVIEW per second: a copy of the frames at 1/4 of their width and "
                 "height for a viewer on another machine (0: none). CAMERA_IMAGE itself never "
                 "leaves this machine, whatever the bus's ttl")
      ->check(cli::Range(0.0, 30.0))
      ->capture_default_str();
  app.add_option("--max-frames", max_frames,
                 "Real sources: stop after this many frames (0: no limit)");
  raster_cache = config::defaultCacheDirectory();
  app.add_option("--raster-cache", raster_cache,
                 "sim: directory for the floor raster cache (default: $XDG_CACHE_HOME/fieldline "
                 "or ~/.cache/fieldline; empty string: none)");
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
}

bus::ProcessIo cameraIo(const CameraAppOptions& options) {
  bus::ProcessIo io("camera");
  if (options.source == "sim") {
    io.reads(bus::channels::kSimWorld);
  } else {
    const bool device = options.source == "v4l2" || options.source == "gstreamer";
    io.link(device ? "camera" : options.source, options.input, bus::Link::Direction::kIn);
  }
  if (options.to_pipe.empty()) {
    io.writes(bus::channels::kCameraImage);
  } else {
    io.link("pipe", options.to_pipe, bus::Link::Direction::kOut);
  }
  if (options.preview_rate > 0.0) io.writes(bus::channels::kCameraPreview);
  return io;
}

// long: one place that opens each camera source (sim, V4L2, file, pipe) with its checks.
int runCamera(const CameraAppOptions& options, const bus::CommonOptions& common) {
  CameraConfig config = loadCameraConfigPreset(options.preset);
  if (options.latency >= 0.0) config.pipeline.latency = options.latency;
  if (options.fps > 0.0) config.pipeline.frame_rate = options.fps;
  // Fail at start, not when the first world state arrives.
  if (options.source == "sim") (void)renderParamsOf(config, "the simulated camera (--source sim)");
  if (!options.to_pipe.empty() && options.source != "sim") {
    throw config::Error("--to-pipe writes rendered frames: it needs --source sim");
  }
  if (options.source != "sim" && options.input.empty()) {
    throw config::Error("--source " + options.source + " needs --input");
  }
  const bool from_log = options.source == "log";
  std::string bus_url = common.bus_url;
  if (from_log && !options.live_bus) {
    // A replayed log never mixes with the robot's live frames.
    bus_url = options.replay_bus_url.empty() ? bus::replayBusUrl(std::max(1, common.robot))
                                             : options.replay_bus_url;
  }
  const RobotClock robot_clock = bus::robotClockFromEnvironment();
  if (common.print_io) return bus::printIo(cameraIo(options));
  if (common.check_args) return device::reportProblems("camera", {sourceProblem(options)});
  // A log with kept stamps runs at the log's time: its first frame is due now.
  std::optional<OffsetClock> log_clock;
  if (from_log && !options.restamp) {
    if (const auto first = LogImageSource::firstUtime(options.input)) {
      const auto latency_us = static_cast<Utime>(config.pipeline.latency * 1e6);
      log_clock.emplace(robot_clock, *first + latency_us - robot_clock.now(), 0.0, 0);
    }
  }
  const Clock& clock = log_clock ? static_cast<const Clock&>(*log_clock) : robot_clock;
  bus::Node node({.process = "camera", .robot_id = common.robot, .url = bus_url}, clock);
  const bus::BusId frames_bus = framesBus(node, bus_url);
  PreviewPublisher preview(node, options.preview_rate);
  if (options.source == "sim") return runSim(node, config, options, common, frames_bus, preview);
  node.declareIo(cameraIo(options));

  bus::installStopSignals();
  std::unique_ptr<FrameSource> source;
  FrameSourceOptions run_options;
  run_options.max_frames = options.max_frames;
  run_options.frames_bus = frames_bus;
  run_options.preview = &preview;
  // Folders, files and logs play at the configured rate; live cameras at their own.
  run_options.pace_fps = config.pipeline.frame_rate;
  if (options.source == "folder") {
    source = std::make_unique<ImageFolderSource>(options.input, options.loop);
  } else if (from_log) {
    source = std::make_unique<LogImageSource>(options.input, options.loop);
    run_options.keep_stamps = !options.restamp;
    if (!options.restamp) run_options.pace_fps = 0.0;
    spdlog::info("replaying {} onto {}{}", options.input, bus_url,
                 options.restamp ? ", restamped" : " with its exposure times");
  } else {
    VideoCaptureOptions vc;
    vc.spec = options.input;
    vc.width = options.width;
    vc.height = options.height;
    vc.fps = options.fps;
    vc.raw_yuyv = !options.bgr;
    vc.loop = options.loop;
    const SourceKind kind = videoSourceKind(options.source);
    // Cameras, pipelines and pipes deliver at their own pace and come back when lost.
    if (kind != SourceKind::kVideo || isNamedPipe(options.input)) {
      run_options.pace_fps = 0.0;
      return runLiveSource(node, kind, vc, config, run_options);
    }
    source = openVideoCapture(kind, vc);
  }
  spdlog::info("publishing {} (latency {} ms)", source->describe(), config.pipeline.latency * 1e3);
  const std::int64_t frames = runFrameSource(node, *source, config.pipeline, run_options);
  spdlog::info("{} frames published, {} unusable", frames, source->errors());
  // A source that gave nothing (a corrupt video, a folder of unreadable images) is a failure,
  // whether or not it could say why (issue 34, red-team finding 10: exit code 0 after 0 frames).
  if (frames == 0) {
    throw std::runtime_error("no frame published from " + source->describe() + ": " +
                             (source->lastError().empty() ? std::string("the source delivered none")
                                                          : source->lastError()));
  }
  return 0;
}

}  // namespace fieldline::camera
