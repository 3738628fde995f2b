// Rendered frames for the evaluation tools, the benchmarks and the tests: a camera preset with its
// colour table and simulated renderer, and robot motions through the field (translation and
// rotation at fixed speeds) to render sequences from. Not part of the node: only the simulator
// renders. Kept in namespace region_tracking, whose inputs these frames are.
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <fieldline/image_t.hpp>

#include "common/camera/colour.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/time/clock.hpp"
#include "services/camera/sim_renderer.hpp"
#include "services/region_tracking/frame_processor.hpp"

namespace fieldline::region_tracking {

struct SimCamera {
  camera::MirrorModel mirror;
  camera::ColourTable table;
  field::FieldModel field;
  std::unique_ptr<camera::SimRenderer> renderer;
  std::vector<std::uint8_t> frame;  // the last rendered YUYV frame

  // Loads config/camera/<cameraPreset>.yaml (image, mirror, colour table, render sections) and
  // config/field/<fieldPreset>.yaml.
  static SimCamera load(const std::string& cameraPreset, const std::string& fieldPreset);

  const camera::FrameView render(const camera::SimScene& scene) {
    renderer->render(scene, frame);
    return renderer->view(frame);
  }

  // Renders the scene as the camera process publishes it: a CAMERA_IMAGE exposed at
  // `exposure_utime`, numbered with the scene's frame number.
  image_t renderImage(const camera::SimScene& scene, Utime exposure_utime);

  // Renders the scene `frames` times (the noise differs per frame number), tracks each with
  // `processor` (lines detected) and returns the last frame's result.
  VisionResult track(FrameProcessor& processor, camera::SimScene scene, int frames = 3) {
    VisionResult result;
    for (int i = 0; i < frames; ++i) {
      scene.frame_number = static_cast<std::uint64_t>(i);
      processor.process(render(scene), true, result);
    }
    return result;
  }
};

struct Motion {
  // Translation speed, m/s, and rotation speed, rad/s.
  double speed = 1.0;
  double omega = 0.0;
  double frame_rate = 30.0;
};

// A box standing on the floor: a footprint of sx x sy centred at `centre`, `height` tall.
camera::SimBox standingBox(const geometry::Vec2& centre, double sx, double sy, double height,
                           camera::Bgr colour);

// A random place in the hall beyond the field's lines, where clutter stands: from 0.4 m beyond a
// touch line (or, unless `side_only`, in 40 % of the draws a goal line) up to 1.5 m beyond the
// carpet's edge.
geometry::Vec2 placeBeyondLines(const field::FieldModel& field, std::mt19937& rng, bool side_only);

// `frames` poses of a robot that drives at `motion.speed` around a rounded rectangle inside the
// field (so it never leaves it) while turning at `motion.omega`. Deterministic for equal input.
std::vector<geometry::Pose2> motionPoses(const field::FieldModel& field, const Motion& motion,
                                         int frames);

}  // namespace fieldline::region_tracking
