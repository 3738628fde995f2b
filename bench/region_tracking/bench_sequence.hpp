// The rendered sequences the benchmark and the profiling tool run on: the robot drives a rounded
// rectangle through the field at a fixed speed while turning at a fixed rate, four other robots
// stand on the field, and a ball rolls along with the robot, circling it at 1.2 m (one turn in
// 12 s), so that it is in view in every frame and its tracking is paid for.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::region_tracking::bench {

// `frameCount` YUYV frames at 30 Hz, `speed` in m/s, `omega_deg` in deg/s.
inline std::vector<std::vector<std::uint8_t>> renderSequence(SimCamera& sim, double speed,
                                                             double omega_deg, int frameCount) {
  const Motion motion{speed, omega_deg * std::numbers::pi / 180.0, 30.0};
  const std::vector<geometry::Pose2> poses = motionPoses(sim.field, motion, frameCount);
  camera::SimScene scene;
  constexpr double kBallDistance = 1.2;                        // m from the robot
  constexpr double kBallTurnRate = 2 * std::numbers::pi / 12;  // rad/s around the robot
  for (const camera::Vec2& p :
       {camera::Vec2(3, -2), camera::Vec2(-4, 1.5), camera::Vec2(0.5, 3.5), camera::Vec2(-2, -3)}) {
    scene.robots.push_back({p, 0.25, false});
  }
  std::vector<std::vector<std::uint8_t>> frames(frameCount);
  for (int i = 0; i < frameCount; ++i) {
    scene.robot = poses[i];
    const double ballBearing = 0.5 + kBallTurnRate * i / motion.frame_rate;  // field frame
    scene.ball = camera::SimBall{{poses[i].x + kBallDistance * std::cos(ballBearing),
                                  poses[i].y + kBallDistance * std::sin(ballBearing)},
                                 0.11};
    scene.frame_number = static_cast<std::uint64_t>(i);
    sim.renderer->render(scene, frames[i]);
  }
  return frames;
}

}  // namespace fieldline::region_tracking::bench
