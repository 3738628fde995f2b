// The whole camera preset as the camera service reads it (config/camera/omni_sim*.yaml): the
// camera model (image size, mirror, colour table name), the renderer's scene settings and the
// timing of the pipeline. The `render` section is the simulator's: a real camera's preset leaves
// it out, and only what renders (the sim source, --render snapshots) asks for it.
#pragma once

#include <optional>
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
  // The simulated renderer's settings; absent in a real camera's preset.
  std::optional<RenderParams> render;
  PipelineParams pipeline;
  // The file it was read from (for messages).
  std::string source;
};

// The render section, or config::Error "<file>: <who> needs a render section ..." where a
// preset without one is used to render.
const RenderParams& renderParamsOf(const CameraConfig& config, const std::string& who);

// Reads every section of a camera preset and rejects unknown keys anywhere in it (`render` is
// optional). Throws config::Error with file:line.
CameraConfig loadCameraConfig(const config::Node& root);
CameraConfig loadCameraConfigPreset(const std::string& name_or_path);

}  // namespace fieldline::camera
