// The delay-aware filter's cost of a late measurement: a line correction 150 ms old arriving at a
// filter that runs 50 Hz odometry over a 1 s window rewinds to the checkpoint before it and
// replays the ~8 odometry steps after it. Issue 10's target: at most 20 µs (median, one core).
//
//   build/bin/fieldline-bench-fusion --benchmark_filter=LateMeasurement
// (BM_LateMeasurementPushInContact: with the push velocity on and the robot in contact.)
#include <benchmark/benchmark.h>

#include "services/fusion/history.hpp"

namespace fieldline::fusion {
namespace {

constexpr Utime kStart = 1'800'000'000'000'000;

OdometryStep stepAt(Utime t_end) {
  OdometryStep s;
  s.t_start = t_end - 20'000;
  s.t_end = t_end;
  s.integrated = Eigen::Vector3d(0.016, 0.002, 0.01);
  s.covariance = Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  return s;
}

// The same with the push velocity on (PushModel) and the robot in contact all the time (contact
// evidence from the currents at every odometry sample): the worst case, every replayed step
// moves the push states and adds the contact noise.
FilterParams inContact() {
  FilterParams p;
  p.contact.hold_us = 50'000;
  p.contact.position_density = 0.3;
  p.contact.gyro_heading_density = 0.3;
  p.contact.heading_density = 1.5;
  p.push.density = 8.0;
  p.push.contact_decay_s = 0.5;
  p.push.free_decay_s = 0.03;
  return p;
}

void lateMeasurement(benchmark::State& state, bool contact) {
  const Utime delay = state.range(0) * kMicrosPerMilli;
  DelayedFilter filter(contact ? inContact() : FilterParams{});
  EkfState start;
  start.utime = kStart;
  filter.initialize(start);
  Utime t = kStart;
  // A full window of history first.
  for (int i = 0; i < 60; ++i) {
    t += 20'000;
    if (contact) filter.addContact(t - 20'000, t);
    filter.addOdometry(stepAt(t), t);
  }
  for (auto _ : state) {
    state.PauseTiming();
    t += 20'000;
    if (contact) filter.addContact(t - 20'000, t);
    filter.addOdometry(stepAt(t), t);
    PoseMeasurement z;
    z.utime = t - delay + 3'000;  // between two odometry samples, as an exposure is
    const auto at = filter.stateAt(z.utime);
    z.pose = at->pose();
    z.pose.x += 0.01;
    z.covariance = Eigen::Vector3d(4e-4, 4e-4, 1e-4).asDiagonal();
    state.ResumeTiming();
    benchmark::DoNotOptimize(filter.addPose(MeasurementSource::kLines, z, t));
  }
  state.counters["replays"] = static_cast<double>(filter.replays());
}

void BM_LateMeasurement(benchmark::State& state) {
  lateMeasurement(state, false);
}
BENCHMARK(BM_LateMeasurement)->Arg(0)->Arg(60)->Arg(150)->Unit(benchmark::kMicrosecond);

void BM_LateMeasurementPushInContact(benchmark::State& state) {
  lateMeasurement(state, true);
}
BENCHMARK(BM_LateMeasurementPushInContact)
    ->Arg(0)
    ->Arg(60)
    ->Arg(150)
    ->Unit(benchmark::kMicrosecond);

void BM_OdometryStep(benchmark::State& state) {
  DelayedFilter filter;
  EkfState start;
  start.utime = kStart;
  filter.initialize(start);
  Utime t = kStart;
  for (auto _ : state) {
    t += 20'000;
    benchmark::DoNotOptimize(filter.addOdometry(stepAt(t), t));
  }
}
BENCHMARK(BM_OdometryStep)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace fieldline::fusion
