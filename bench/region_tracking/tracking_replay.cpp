// fieldline-replay-tracking: the region tracking node's per-frame work (FrameProcessor::process
// and the vision health) on the frames of a recording of the running team, or on the tracking
// benchmark's rendered sequence, with the caches warm (a frame's fastest of several rounds, as the
// benchmark times it) or cold (before every frame a buffer of --evict-mb MB is written, as the
// other processes of a team on a shared machine do between two of a process's frames; the frame
// itself is then copied in, as the kernel does on receipt).
//
//   fieldline-record --robot 1 --images 1 --channel CAMERA_IMAGE --channel ROBOT_STATE -o REC
//   fieldline-replay-tracking --log REC/robot1.lcm [--evict-mb 64] [--rounds 5]
//   fieldline-replay-tracking --bench [--evict-mb 64]
//
// Prints per frame the median and mean of process() and of the health's update, in us; under
// `valgrind --tool=callgrind --toggle-collect=...` it counts a frame's instructions.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/LU>

#include "bench/region_tracking/bench_sequence.hpp"
#include "bench/replay_summary.hpp"
#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"
#include "common/bus/log_file.hpp"
#include "common/cli/cli.hpp"
#include "common/geometry/geometry.hpp"
#include "common/msg/estimates.hpp"
#include "common/msg/image.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "services/region_tracking/vision_health.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace cli = fieldline::cli;
namespace rt = fieldline::region_tracking;
namespace camera = fieldline::camera;
namespace bus = fieldline::bus;
namespace perception = fieldline::perception;
namespace geometry = fieldline::geometry;

namespace {

using Clock = std::chrono::steady_clock;

struct Frame {
  std::vector<std::uint8_t> pixels;
  std::optional<rt::FramePose> pose;
};

// The node's poseAt(): fusion's newest TRACKING state carried to the frame's time.
std::optional<rt::FramePose> poseAt(const std::optional<perception::RobotEstimate>& state,
                                    std::int64_t utime) {
  if (!state || state->status != perception::LocalizationStatus::kTracking) return std::nullopt;
  const perception::RobotEstimate& e = *state;
  const std::int64_t age = utime - e.utime;
  if (std::abs(age) > 200'000) return std::nullopt;
  const double dt = static_cast<double>(age) * 1e-6;
  rt::FramePose out;
  out.pose = {e.pose.x + e.vx * dt, e.pose.y + e.vy * dt,
              geometry::normalizeAngle(e.pose.phi + e.omega * dt)};
  const Eigen::Matrix2d position = e.covariance.topLeftCorner<2, 2>();
  const double trace = position.trace();
  const double det = position.determinant();
  out.sigma_m =
      std::sqrt(std::max(0.0, 0.5 * trace + std::sqrt(std::max(0.0, 0.25 * trace * trace - det))));
  return out;
}

std::vector<Frame> readLog(const std::string& path, int maxFrames) {
  bus::LogReader reader(path);
  bus::LogEvent event;
  std::optional<perception::RobotEstimate> state;
  std::vector<Frame> frames;
  while (reader.nextEvent(event) && static_cast<int>(frames.size()) < maxFrames) {
    const int size = static_cast<int>(event.data.size());
    if (event.channel == bus::channels::kRobotState.name) {
      fieldline::robot_state_t m;
      if (!bus::decodeChecked(m, event.data.data(), size)) {
        const perception::RobotEstimate e = fieldline::msg::fromMessage(m);
        if (!state || e.utime >= state->utime) state = e;
      }
    } else if (event.channel == bus::channels::kCameraImage.name) {
      fieldline::image_t m;
      if (bus::decodeChecked(m, event.data.data(), size)) continue;
      frames.push_back({m.data, poseAt(state, m.header.utime)});
    }
  }
  return frames;
}

struct Times {
  std::vector<double> process, health, track, lines, ball;
};

double micros(Clock::duration d) {
  return std::chrono::duration<double, std::micro>(d).count();
}

}  // namespace

// long: options, frames and the timed rounds in one place, as the other benchmarks' mains.
int main(int argc, char** argv) {
  cli::App app{"Region tracking's per-frame work on recorded or rendered frames, warm or cold"};
  std::string log;
  bool bench = false;
  int rounds = 5;
  int maxFrames = 600;
  double evictMb = 0;
  bool noPose = false;
  int evictStride = 64;
  bool stages = false;
  app.add_option("--log", log, "recording (robot bus: CAMERA_IMAGE and ROBOT_STATE)");
  app.add_flag("--bench", bench, "the tracking benchmark's default sequence (240 frames)");
  app.add_option("--rounds", rounds, "rounds; a frame's time is its fastest")
      ->capture_default_str();
  app.add_option("--frames", maxFrames, "at most this many frames")->capture_default_str();
  app.add_option("--evict-mb", evictMb, "write this many MB before every frame (0: warm)");
  app.add_option("--evict-stride", evictStride,
                 "bytes between two writes of the eviction (4096: a line a page, TLB mostly)")
      ->capture_default_str();
  app.add_flag("--stages", stages,
               "time tracking, lines and ball + obstacles apart (process()'s calls)");
  app.add_flag("--no-pose", noPose, "without fusion's pose (no field checks)");
  FIELDLINE_CLI_PARSE(app, argc, argv);

  rt::SimCamera sim = rt::SimCamera::load("omni_sim", "msl");
  std::vector<Frame> frames;
  if (bench) {
    for (auto& f : rt::bench::renderSequence(sim, 1.0, 90.0, std::min(maxFrames, 240)))
      frames.push_back({std::move(f), std::nullopt});
  } else {
    frames = readLog(log, maxFrames);
  }
  int posed = 0;
  for (Frame& f : frames) {
    if (noPose) f.pose.reset();
    posed += f.pose ? 1 : 0;
  }
  std::printf("%zu frames (%d with a pose), %d rounds, evict %.0f MB\n", frames.size(), posed,
              rounds, evictMb);
  std::vector<std::uint8_t> evict(static_cast<std::size_t>(evictMb * 1e6));
  std::vector<std::uint8_t> delivered(frames.empty() ? 0 : frames[0].pixels.size());
  const rt::VisionParams params = rt::defaultVisionParams();
  std::vector<Times> byRound(static_cast<std::size_t>(rounds));
  for (int r = 0; r < rounds; ++r) {
    rt::FrameProcessor processor(sim.mirror, sim.table, params);
    rt::VisionHealth health(sim.mirror, sim.table, rt::VisionHealthParams{}, &sim.field,
                            &processor.classLookup());
    rt::VisionResult result;
    for (const Frame& f : frames) {
      for (std::size_t i = 0; i < evict.size(); i += static_cast<std::size_t>(evictStride))
        evict[i] = static_cast<std::uint8_t>(evict[i] + 1);
      std::copy(f.pixels.begin(), f.pixels.end(), delivered.begin());
      const camera::FrameView view = sim.renderer->view(delivered);
      rt::BallRegion ballRegion;
      if (f.pose) {
        ballRegion = rt::BallRegion{&sim.field, f.pose->pose, f.pose->sigma_m};
        processor.setBallRegion(ballRegion);
      } else {
        processor.setBallRegion(std::nullopt);
      }
      const Clock::time_point t0 = Clock::now();
      if (stages) {
        processor.classifier().setFrame(view);
        result.tracking = processor.tracker().track(processor.classifier());
        const Clock::time_point ta = Clock::now();
        result.lines_detected = true;
        processor.lineDetector().detect(view, processor.tracker().contours(), result.lines);
        const Clock::time_point tb = Clock::now();
        result.ball = processor.ballDetector().detect(view, processor.tracker().contours(),
                                                      f.pose ? &ballRegion : nullptr);
        processor.obstacleDetector().detect(processor.tracker().contours(), result.obstacles);
        byRound[r].track.push_back(micros(ta - t0));
        byRound[r].lines.push_back(micros(tb - ta));
        byRound[r].ball.push_back(micros(Clock::now() - tb));
      } else {
        processor.process(view, true, result);
      }
      const Clock::time_point t1 = Clock::now();
      health.update(view, result, f.pose);
      const Clock::time_point t2 = Clock::now();
      byRound[r].process.push_back(micros(t1 - t0));
      byRound[r].health.push_back(micros(t2 - t1));
    }
  }
  Times fastest = byRound[0];
  for (int r = 1; r < rounds; ++r) {
    for (std::size_t i = 0; i < frames.size(); ++i) {
      fastest.process[i] = std::min(fastest.process[i], byRound[r].process[i]);
      fastest.health[i] = std::min(fastest.health[i], byRound[r].health[i]);
      if (stages) {
        fastest.track[i] = std::min(fastest.track[i], byRound[r].track[i]);
        fastest.lines[i] = std::min(fastest.lines[i], byRound[r].lines[i]);
        fastest.ball[i] = std::min(fastest.ball[i], byRound[r].ball[i]);
      }
    }
  }
  // The first frame (initial search) left out, as the benchmark does.
  fastest.process.erase(fastest.process.begin());
  fastest.health.erase(fastest.health.begin());
  for (std::vector<double>* v : {&fastest.track, &fastest.lines, &fastest.ball})
    if (!v->empty()) v->erase(v->begin());
  fieldline::bench::printReplaySummary("process", fastest.process);
  if (stages) {
    fieldline::bench::printReplaySummary("track", fastest.track);
    fieldline::bench::printReplaySummary("lines", fastest.lines);
    fieldline::bench::printReplaySummary("ball+obs", fastest.ball);
  }
  fieldline::bench::printReplaySummary("health", fastest.health);
  return 0;
}
