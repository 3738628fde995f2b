// fieldline-camera: one robot's camera. Publishes CAMERA_IMAGE on the robot's bus from
//   --source sim        rendered from SIM_WORLD (simulator bus) at the preset's frame rate
//   --source v4l2       a V4L2 camera (--input /dev/video0), raw YUYV unless --bgr
//   --source video      a video file (--input clip.avi)
//   --source gstreamer  a GStreamer pipeline ending in appsink (--input "...")
//   --source folder     PNG/JPEG/BMP files of a folder in name order (--input dir)
//   --source log        CAMERA_IMAGE frames of an LCM log (--input file.lcmlog)
// utime is the exposure time: the render tick for sim, receive time - latency for cameras and
// files. A log keeps its recorded exposure times (--keep-stamps, the default; --restamp to
// stamp like a camera) and goes onto robot N's replay bus unless --live-bus (camera_app.hpp).
#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"
#include "services/camera/camera_app.hpp"

namespace cli = fieldline::cli;
namespace bus = fieldline::bus;

int main(int argc, char** argv) {
  cli::App app{"Camera of one robot: publishes CAMERA_IMAGE (simulated or real source)"};
  bus::CommonOptions common;
  common.addTo(app);
  fieldline::camera::CameraAppOptions options;
  options.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);
  common.resolve("camera");
  return bus::runMain("camera", [&] { return fieldline::camera::runCamera(options, common); });
}
