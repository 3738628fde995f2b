// The whole camera preset as the camera service reads it (config/camera/omni_sim*.yaml): the
// camera model (image size, mirror, colour table name), the renderer's scene settings and the
// timing of the pipeline.
#pragma once

#include <string>

#include "common/camera/mirror_model.hpp"
#include "services/camera/sim_renderer.hpp"

namespace fieldline::camera {

struct PipelineParams {
  // Frames per second the source delivers (the sim source renders at this rate), Hz.
  double frame_rate = 30.0;
  // Exposure duration, s.
  double exposure = 0.008;
  // Time from the middle of the exposure to delivery, s: utime = delivery time - latency.
  double latency = 0.060;
};

struct CameraConfig {
  CameraModel model;
  RenderParams render;
  PipelineParams pipeline;
};

// Reads every section of a camera preset and rejects unknown keys anywhere in it. Throws
// config::Error with file:line.
CameraConfig loadCameraConfig(const config::Node& root);
CameraConfig loadCameraConfigPreset(const std::string& name_or_path);

}  // namespace fieldline::camera
