#include "services/camera/camera_config.hpp"

namespace fieldline::camera {

CameraConfig loadCameraConfig(const config::Node& root) {
  CameraConfig c;
  c.model = loadCameraModel(root);
  if (const std::optional<config::Node> render = root.childIf("render")) {
    c.render = loadRenderParams(*render);
  }
  const config::Node p = root.child("pipeline");
  c.pipeline.frame_rate = p.get<double>("frame_rate", 1.0, 240.0);
  c.pipeline.exposure = p.get<double>("exposure", 0.0, 0.1);
  c.pipeline.latency = p.get<double>("latency", 0.0, 1.0);
  p.rejectUnknownKeys();
  root.rejectUnknownKeys();
  return c;
}

CameraConfig loadCameraConfigPreset(const std::string& name_or_path) {
  const std::string path = config::resolvePreset("camera", name_or_path);
  CameraConfig c = loadCameraConfig(config::Node::loadFile(path));
  c.source = path;
  return c;
}

const RenderParams& renderParamsOf(const CameraConfig& config, const std::string& who) {
  if (!config.render) {
    throw config::Error((config.source.empty() ? std::string("camera preset") : config.source) +
                        ": " + who +
                        " needs a `render` section (the simulator's scene settings); a real "
                        "camera's preset has none: use config/camera/omni_sim.yaml's as a start");
  }
  return *config.render;
}

}  // namespace fieldline::camera
