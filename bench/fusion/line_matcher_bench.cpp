// Layer 2 on one frame of realistic line points: the msl field rendered by the omni_sim_640
// camera at (-2, -1.5, 2.0) and run through the region tracker (400 points), corrected with
// both methods from a typical guess (odometry's error between two vision frames: 3.5 cm, 1 deg)
// and from the tests' worst case (30 cm, 10 deg). Also one cost evaluation and the global search.
//
//   nice build/bin/fieldline-bench-fusion --benchmark_filter=Matcher
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <vector>

#include "services/fusion/line_matcher.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace {

using fieldline::fusion::LineMatcher;
using fieldline::fusion::MatcherParams;
using fieldline::fusion::MatchMethod;
using fieldline::geometry::Pose2;
using fieldline::perception::LinePoint;
namespace rt = fieldline::region_tracking;

constexpr Pose2 kTruth{-2.0, -1.5, 2.0};
constexpr std::size_t kPoints = 400;

struct Scene {
  fieldline::field::FieldModel field;
  std::vector<LinePoint> points;
};

const Scene& scene() {
  static const Scene instance = [] {
    rt::SimCamera sim = rt::SimCamera::load("omni_sim_640", "msl");
    rt::FrameProcessor processor(sim.mirror, sim.table, rt::defaultVisionParams());
    fieldline::camera::SimScene s;
    s.robot = kTruth;
    rt::VisionResult result;
    for (int i = 0; i < 3; ++i) {
      s.frame_number = static_cast<std::uint64_t>(i);
      processor.process(sim.render(s), true, result);
    }
    std::vector<LinePoint> points = result.lines.points;
    if (points.size() > kPoints) points.resize(kPoints);
    return Scene{sim.field, points};
  }();
  return instance;
}

const LineMatcher& matcher(MatchMethod method) {
  auto make = [](MatchMethod m) {
    MatcherParams p;
    p.method = m;
    return LineMatcher(
        scene().field, p,
        (std::filesystem::temp_directory_path() / "fieldline_bench_grid_cache").string());
  };
  static const LineMatcher force = make(MatchMethod::kForceField);
  static const LineMatcher least = make(MatchMethod::kRobustLeastSquares);
  return method == MatchMethod::kForceField ? force : least;
}

// Args: method (0 force field, 1 least squares), offset (0 typical, 1 worst case).
void BM_MatcherCorrect(benchmark::State& state) {
  const MatchMethod method =
      state.range(0) == 0 ? MatchMethod::kForceField : MatchMethod::kRobustLeastSquares;
  const bool far = state.range(1) == 1;
  const LineMatcher& m = matcher(method);
  const std::vector<LinePoint>& points = scene().points;
  const double offset = far ? 0.30 : 0.035;
  const double turn = (far ? 10.0 : 1.0) * std::numbers::pi / 180.0;
  const Pose2 guess{kTruth.x + offset * std::cos(0.7), kTruth.y + offset * std::sin(0.7),
                    kTruth.phi + turn};
  fieldline::fusion::PoseCorrection c;
  for (auto _ : state) {
    c = m.correct(points, guess, 0);
    benchmark::DoNotOptimize(c);
  }
  state.counters["points"] = static_cast<double>(points.size());
  state.counters["iterations"] = c.iterations;
  state.counters["error_mm"] = 1000.0 * std::hypot(c.pose.x - kTruth.x, c.pose.y - kTruth.y);
  state.SetLabel(std::string(method == MatchMethod::kForceField ? "force_field" : "least_squares") +
                 (far ? " 30cm/10deg" : " 3.5cm/1deg"));
}
BENCHMARK(BM_MatcherCorrect)
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Unit(benchmark::kMicrosecond)
    ->MinTime(0.2);

void BM_MatcherCost(benchmark::State& state) {
  const LineMatcher& m = matcher(MatchMethod::kRobustLeastSquares);
  for (auto _ : state)
    benchmark::DoNotOptimize(m.cost(scene().points, kTruth));
  state.counters["points"] = static_cast<double>(scene().points.size());
}
BENCHMARK(BM_MatcherCost)->Unit(benchmark::kMicrosecond)->MinTime(0.2);

void BM_MatcherGlobalSearch(benchmark::State& state) {
  const LineMatcher& m = matcher(MatchMethod::kRobustLeastSquares);
  for (auto _ : state)
    benchmark::DoNotOptimize(m.globalSearch(scene().points));
}
BENCHMARK(BM_MatcherGlobalSearch)->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace
