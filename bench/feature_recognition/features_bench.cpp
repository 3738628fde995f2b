// The feature recogniser on line points recorded from rendered frames (omni_sim camera, msl
// field): 200 poses along a drive through the field, each tracked over three frames, then the
// recogniser alone timed per frame.
//
//   build/bin/fieldline-bench-features --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <benchmark/benchmark.h>

#include <vector>

#include "services/feature_recognition/recognizer.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tests/support/sim_frames.hpp"

namespace {

using namespace fieldline;

struct Recorded {
  field::FieldModel field;
  std::vector<perception::LinePoints> frames;
  double mean_points = 0.0;
};

const Recorded& recorded() {
  static const Recorded data = [] {
    region_tracking::SimCamera sim = region_tracking::SimCamera::load("omni_sim", "msl");
    region_tracking::FrameProcessor processor(sim.mirror, sim.table,
                                              region_tracking::defaultVisionParams());
    region_tracking::VisionResult result;
    Recorded r{sim.field, {}, 0.0};
    const auto poses = region_tracking::motionPoses(sim.field, {2.0, 1.0, 10.0}, 200);
    double total = 0.0;
    for (std::size_t i = 0; i < poses.size(); ++i) {
      camera::SimScene scene;
      scene.robot = poses[i];
      scene.frame_number = i;
      processor.process(sim.render(scene), true, result);
      r.frames.push_back(result.lines);
      total += static_cast<double>(result.lines.points.size());
    }
    r.mean_points = total / static_cast<double>(poses.size());
    return r;
  }();
  return data;
}

void BM_RecognizeFrame(benchmark::State& state) {
  const Recorded& data = recorded();
  feature_recognition::FeatureRecognizer recognizer(data.field);
  perception::FieldFeatures out;
  std::size_t i = 0;
  for (auto _ : state) {
    recognizer.recognize(data.frames[i], out);
    benchmark::DoNotOptimize(out.hypotheses.data());
    i = (i + 1) % data.frames.size();
  }
  state.counters["points_per_frame"] = data.mean_points;
}
BENCHMARK(BM_RecognizeFrame)->Unit(benchmark::kMicrosecond);

}  // namespace
