// fieldline-bench-first-frame: what a region tracking processor costs before it runs at its
// usual rate: its construction (as the node does on its first frame and on every change of
// frame size) and its first frames with a ball in view (the ball detector samples its edge-inset
// table where a ball is first placed: services/region_tracking/ball_detector_insets.hpp), against
// its later frames. Several processors in one process show what the process-wide table saves.
//
//   fieldline-bench-first-frame [--camera omni_sim_640] [--ball-range 4.6] [--processors 3]
//
// Times are the thread's CPU time (CLOCK_THREAD_CPUTIME_ID), ms: a loaded machine stretches the
// wall time, not these.
#include <time.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/cli/cli.hpp"
#include "common/geometry/geometry.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace cli = fieldline::cli;
namespace rt = fieldline::region_tracking;
namespace camera = fieldline::camera;
namespace geometry = fieldline::geometry;

namespace {

double cpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{"A region tracking processor's construction and first frames, CPU ms"};
  std::string cameraPreset = "omni_sim";
  double range = 4.6;
  int processors = 3;
  int frames = 5;
  app.add_option("--camera", cameraPreset, "camera preset")->capture_default_str();
  app.add_option("--ball-range", range, "the ball's distance from the robot, m (0: no ball)")
      ->check(cli::Range(0.0, 8.0))
      ->capture_default_str();
  app.add_option("--processors", processors, "processors built one after the other")
      ->check(cli::Range(1, 100))
      ->capture_default_str();
  app.add_option("--frames", frames, "frames each processor tracks (the same rendered frame)")
      ->check(cli::Range(3, 1000))
      ->capture_default_str();
  FIELDLINE_CLI_PARSE(app, argc, argv);

  rt::SimCamera sim = rt::SimCamera::load(cameraPreset, "msl");
  camera::SimScene scene;
  scene.robot = geometry::Pose2{0.0, -2.0, 0.0};
  if (range > 0) {
    const geometry::Vec2 inRobot = range * geometry::Vec2(std::cos(0.4), std::sin(0.4));
    scene.ball = camera::SimBall{geometry::pointRobotToField(scene.robot, inRobot), 0.11};
  }
  const camera::FrameView view = sim.render(scene);
  std::printf("%s %dx%d, ball at %.2f m\n", cameraPreset.c_str(), sim.mirror.width(),
              sim.mirror.height(), range);
  const rt::VisionParams params = rt::defaultVisionParams();
  for (int p = 0; p < processors; ++p) {
    const double t0 = cpuMs();
    rt::FrameProcessor processor(sim.mirror, sim.table, params);
    const double t1 = cpuMs();
    rt::VisionResult result;
    std::vector<double> frameMs;
    for (int i = 0; i < frames; ++i) {
      const double s = cpuMs();
      processor.process(view, true, result);
      frameMs.push_back(cpuMs() - s);
    }
    double later = 0;
    for (int i = 2; i < frames; ++i)
      later = std::max(later, frameMs[i]);
    std::printf(
        "processor %d: construct %.2f ms, frame 1 %.2f ms, frame 2 %.2f ms, frames 3-%d at most "
        "%.2f ms; ball %s at %.3f m, %d inset cells sampled\n",
        p + 1, t1 - t0, frameMs[0], frameMs[1], frames, later,
        result.ball.visible ? "seen" : "not seen", std::hypot(result.ball.x, result.ball.y),
        processor.ballDetector().edgeInsetTable().cellsSampled());
  }
  return 0;
}
