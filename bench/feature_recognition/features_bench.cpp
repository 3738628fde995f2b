// The feature recogniser alone, timed per frame, on two sets of line points:
//
//   BM_RecognizeRecordedMatch640  VISION_LINES recorded from a simulated match
//       (bench/data/vision_lines_match_640.lcmlog: robot 1 of the match scenario with the 640x480
//       camera preset, about 400 points per frame; bench/data/make_vision_lines_log.sh). This is
//       the benchmark.
//   BM_RecognizeRendered320       200 frames rendered in-process along a drive through the field
//       with the 320x240 omni_sim camera (about 160 points per frame), for comparison.
//
//   build/bin/fieldline-bench-features --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <benchmark/benchmark.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "common/bus/log_file.hpp"
#include "common/config/config.hpp"
#include "common/msg/line_contours.hpp"
#include "services/feature_recognition/recognizer.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace {

using namespace fieldline;

struct Recorded {
  field::FieldModel field;
  std::vector<perception::LinePoints> frames;
  double mean_points = 0.0;
};

void addFrame(Recorded& r, const perception::LinePoints& lines) {
  const double n = static_cast<double>(r.frames.size());
  r.mean_points = (r.mean_points * n + static_cast<double>(lines.points.size())) / (n + 1);
  r.frames.push_back(lines);
}

const Recorded& recordedMatch() {
  static const Recorded data = [] {
    const std::string path = config::projectRoot() + "/bench/data/vision_lines_match_640.lcmlog";
    Recorded r{field::loadFieldPreset("msl"), {}, 0.0};
    bus::LogReader log(path);
    line_contours_t message;
    perception::LinePoints lines;
    while (log.next(bus::channels::kVisionLines, message)) {
      msg::fromMessage(message, lines);
      addFrame(r, lines);
    }
    if (r.frames.empty()) throw std::runtime_error(path + ": no VISION_LINES");
    return r;
  }();
  return data;
}

const Recorded& rendered320() {
  static const Recorded data = [] {
    region_tracking::SimCamera sim = region_tracking::SimCamera::load("omni_sim", "msl");
    region_tracking::FrameProcessor processor(sim.mirror, sim.table,
                                              region_tracking::defaultVisionParams());
    region_tracking::VisionResult result;
    Recorded r{sim.field, {}, 0.0};
    const auto poses = region_tracking::motionPoses(sim.field, {2.0, 1.0, 10.0}, 200);
    for (std::size_t i = 0; i < poses.size(); ++i) {
      camera::SimScene scene;
      scene.robot = poses[i];
      scene.frame_number = i;
      processor.process(sim.render(scene), true, result);
      addFrame(r, result.lines);
    }
    return r;
  }();
  return data;
}

void recognizeFrames(benchmark::State& state, const Recorded& data,
                     const feature_recognition::RecognitionParams& params = {}) {
  feature_recognition::FeatureRecognizer recognizer(data.field, params);
  perception::FieldFeatures out;
  std::size_t i = 0;
  for (auto _ : state) {
    recognizer.recognize(data.frames[i], out);
    benchmark::DoNotOptimize(out.hypotheses.data());
    i = (i + 1) % data.frames.size();
  }
  state.counters["points_per_frame"] = data.mean_points;
  state.counters["frames"] = static_cast<double>(data.frames.size());
}

// The defaults: since features9h with the alone rule, the L tests of stages 8 and 9 and the goals'
// shadow.
void BM_RecognizeRecordedMatch640(benchmark::State& state) {
  recognizeFrames(state, recordedMatch());
}
BENCHMARK(BM_RecognizeRecordedMatch640)->Unit(benchmark::kMicrosecond);

// The recogniser without those rules (the defaults before features9h): their cost.
feature_recognition::RecognitionParams rulesOffParams() {
  feature_recognition::RecognitionParams params;
  params.line_end_alone_side_points = 0;
  params.line_end_max_beyond_points = -1;
  params.identity_max_beyond_points = -1;
  params.model_check_goal_shadow = false;
  return params;
}

void BM_RecognizeRecordedMatch640RulesOff(benchmark::State& state) {
  recognizeFrames(state, recordedMatch(), rulesOffParams());
}
BENCHMARK(BM_RecognizeRecordedMatch640RulesOff)->Unit(benchmark::kMicrosecond);

void BM_RecognizeRendered320(benchmark::State& state) {
  recognizeFrames(state, rendered320());
}
BENCHMARK(BM_RecognizeRendered320)->Unit(benchmark::kMicrosecond);

}  // namespace
