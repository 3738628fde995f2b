#include "services/camera/camera_config.hpp"

namespace fieldline::camera {

CameraConfig loadCameraConfig(const config::Node& root) {
  CameraConfig c;
  c.model = loadCameraModel(root);
  c.render = loadRenderParams(root.child("render"));
  const config::Node p = root.child("pipeline");
  c.pipeline.frame_rate = p.get<double>("frame_rate", 1.0, 240.0);
  c.pipeline.exposure = p.get<double>("exposure", 0.0, 0.1);
  c.pipeline.latency = p.get<double>("latency", 0.0, 1.0);
  p.rejectUnknownKeys();
  root.rejectUnknownKeys();
  return c;
}

CameraConfig loadCameraConfigPreset(const std::string& name_or_path) {
  return loadCameraConfig(config::Node::loadFile(config::resolvePreset("camera", name_or_path)));
}

}  // namespace fieldline::camera
