// The rendered sequences the benchmark and the profiling tool run on: the robot drives a rounded
// rectangle through the field at a fixed speed while turning at a fixed rate, with a ball and
// four other robots standing on the field.
#pragma once

#include <cstdint>
#include <numbers>
#include <vector>

#include "tests/support/sim_frames.hpp"

namespace fieldline::region_tracking::bench {

// `frameCount` YUYV frames at 30 Hz, `speed` in m/s, `omegaDeg` in deg/s.
inline std::vector<std::vector<std::uint8_t>> renderSequence(SimCamera& sim, double speed,
                                                             double omegaDeg, int frameCount) {
  const Motion motion{speed, omegaDeg * std::numbers::pi / 180.0, 30.0};
  const std::vector<geometry::Pose2> poses = motionPoses(sim.field, motion, frameCount);
  camera::SimScene scene;
  scene.ball = camera::SimBall{{1.5, 1.0}, 0.11};
  for (const camera::Vec2& p :
       {camera::Vec2(3, -2), camera::Vec2(-4, 1.5), camera::Vec2(0.5, 3.5), camera::Vec2(-2, -3)}) {
    scene.robots.push_back({p, 0.25, false});
  }
  std::vector<std::vector<std::uint8_t>> frames(frameCount);
  for (int i = 0; i < frameCount; ++i) {
    scene.robot = poses[i];
    scene.frame_number = static_cast<std::uint64_t>(i);
    sim.renderer->render(scene, frames[i]);
  }
  return frames;
}

}  // namespace fieldline::region_tracking::bench
