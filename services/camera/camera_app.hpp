// The camera process without its command line: which source to open, and the loop that publishes
// its frames as CAMERA_IMAGE (services/camera/main.cpp parses the options into CameraAppOptions).
#pragma once

#include <cstdint>
#include <string>

#include "common/bus/cli.hpp"
#include "common/bus/io.hpp"
#include "common/cli/cli.hpp"

namespace fieldline::camera {

struct CameraAppOptions {
  // sim, v4l2, video, gstreamer, folder or log.
  std::string source = "sim";
  // Camera preset (config/camera/<name>.yaml) or a path.
  std::string preset = "omni_sim";
  // sim: field preset to render; empty: the field SIM_WORLD names.
  std::string field;
  // v4l2 device or index, video file, GStreamer pipeline, image folder or LCM log.
  std::string input;
  // Exposure-to-delivery latency, s; negative: the preset's.
  double latency = -1.0;
  // v4l2: requested rate; folder/video/log: pace. 0: the preset's.
  double fps = 0.0;
  // v4l2: requested size, px; 0: the driver's.
  int width = 0;
  int height = 0;
  // folder/video/log: start again at the end.
  bool loop = false;
  // v4l2: OpenCV's BGR frames instead of raw YUYV.
  bool bgr = false;
  // Real sources: stop after this many frames; 0: no limit.
  std::int64_t max_frames = 0;
  // log: keep the logged exposure times (the default): the process runs on a clock at the log's
  // time and publishes each frame when its time comes. --restamp: receive time - latency at fps.
  bool keep_stamps = true;
  bool restamp = false;
  // log: publish on --bus-url (the live bus) instead of robot N's replay bus.
  bool live_bus = false;
  // log: the bus the frames go to; empty: bus::replayBusUrl(robot).
  std::string replay_bus_url;
  // sim: write the frames into this named pipe as YUV4MPEG2 (made if missing) instead of
  // publishing CAMERA_IMAGE: a stand-in camera device for a real robot's launch (rehearsal).
  std::string to_pipe;
  // sim: directory of the floor raster cache (floor_raster_cache.hpp); empty: none. Set to
  // config::defaultCacheDirectory() by addTo().
  std::string raster_cache;
  // CAMERA_PREVIEW messages per second (a 1/kCameraPreviewScale copy of the frames for a viewer
  // on another machine); 0: none. The full frames never leave the machine: when the bus has a
  // ttl, CAMERA_IMAGE goes out through a ttl=0 copy of it (bus::localOnlyUrl).
  double preview_rate = 0.0;

  // Adds --source, --config, --field, --input, --latency, --fps, --width, --height, --loop, --bgr,
  // --max-frames, --raster-cache, --keep-stamps, --restamp, --live-bus, --replay-bus-url,
  // --to-pipe and --preview-rate to `app`.
  void addTo(cli::App& app);
};

// Opens the source and publishes its frames until stopped (SIGINT/SIGTERM), the source ends or
// max_frames were sent. With common.check_args, reads the preset and checks the options, then
// returns 0 before opening a bus or a device (config::Error for a problem: exit code 2). A live
// camera (v4l2, gstreamer) that fails is reported and reopened every second. Throws
// std::runtime_error for a source that cannot be used (e.g. no --input), and when a finite source
// published no frame. Returns the process's exit code.
int runCamera(const CameraAppOptions& options, const bus::CommonOptions& common);

// What the camera reads and writes with `options` (fieldline-camera --print-io): the simulator's
// SIM_WORLD or a device, file or pipeline; CAMERA_IMAGE (or a named pipe) and CAMERA_PREVIEW.
bus::ProcessIo cameraIo(const CameraAppOptions& options);

}  // namespace fieldline::camera
