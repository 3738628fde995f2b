// fieldline-bench-tracking: the region tracker against the two full-frame baselines on the same
// rendered sequences, in one process on one thread (seed table 3.1 and the comparison after it).
//
// For every sequence (robot translating or rotating at a fixed speed through the msl field, with
// a ball and four other robots standing on it) the frames are rendered first and kept in memory;
// then each method runs over all of them and every frame is timed:
//   tracker   grow/shrink tracking + boundaries        (+ line points: the "whole step")
//   cmvision  baseline (a): classify all cells, RLE, union-find, boundaries (+ the same line
//   points) opencv    baseline (b): mask per class, connectedComponentsWithStats, findContours
// All use the same cells (same size, same block classifier, same don't-touch mask, same classes).
// The first frame (initial search) is left out of the times. The last line is
//   ratio_vs_cmvision=X ratio_vs_opencv=Y touched_fraction=Z
// for 320x240, 4x4 cells, 1 m/s and 90 deg/s (median time ratios; tracker without lines).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include "bench/region_tracking/bench_sequence.hpp"
#include "common/config/config.hpp"
#include "services/region_tracking/baselines.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tests/support/sim_frames.hpp"

namespace rt = fieldline::region_tracking;
namespace camera = fieldline::camera;

namespace {

using Clock = std::chrono::steady_clock;

double microseconds(Clock::duration d) {
  return std::chrono::duration<double, std::micro>(d).count();
}

struct Summary {
  double median = 0, p95 = 0;
};

Summary summarise(std::vector<double> values) {
  if (values.empty()) return {};
  std::sort(values.begin(), values.end());
  auto at = [&](double q) {
    return values[static_cast<std::size_t>(q * (values.size() - 1) + 0.5)];
  };
  return {at(0.5), at(0.95)};
}

struct Sequence {
  std::string camera;  // preset
  double speed;        // m/s
  double omegaDeg;     // deg/s
  std::string kind;    // "translation", "rotation", "default"
};

struct Result {
  Sequence sequence;
  int cellSize = 0;
  int frames = 0;
  Summary tracker, trackerWhole, cmvision, cmvisionWhole, cmvisionMasked, opencv;
  double touched = 0, touchedWithLines = 0, overlap = 0;
  int initialSearches = 0;
  double linePoints = 0;
  // Agreement with baseline (a) after every tracked frame.
  int exactFrames = 0, partialRegions = 0, staleCells = 0, untrackedRegions = 0;
};

std::vector<rt::ClassId> trackedClasses(const rt::VisionParams& params) {
  std::vector<rt::ClassId> classes;
  for (const rt::ClassTracking& c : params.tracker.classes)
    classes.push_back(c.classId);
  return classes;
}

Result run(rt::SimCamera& sim, const Sequence& sequence, int cellSize, int frameCount,
           bool coldFrames) {
  Result result;
  result.sequence = sequence;
  result.cellSize = cellSize;
  result.frames = frameCount;

  // Render the sequence once.
  const std::vector<std::vector<std::uint8_t>> frames =
      rt::bench::renderSequence(sim, sequence.speed, sequence.omegaDeg, frameCount);
  // Each method gets the frame the way the node does: the LCM handler has just decoded (copied)
  // the message, so the frame is in the cache. --cold reads the stored frames directly.
  std::vector<std::uint8_t> delivered(frames[0].size());
  auto view = [&](int i) {
    if (coldFrames) return sim.renderer->view(frames[i]);
    std::copy(frames[i].begin(), frames[i].end(), delivered.begin());
    return sim.renderer->view(delivered);
  };

  rt::VisionParams params = rt::defaultVisionParams();
  params.tracker.cellSize = cellSize;
  const std::vector<rt::ClassId> classes = trackedClasses(params);

  // Tracker (and line points on its boundaries).
  {
    rt::FrameProcessor processor(sim.mirror, sim.table, params);
    rt::LinePoints lines;
    std::vector<double> segment, whole;
    double touched = 0, touchedLines = 0, overlap = 0, points = 0;
    const double pixels = static_cast<double>(sim.mirror.width()) * sim.mirror.height();
    for (int i = 0; i < frameCount; ++i) {
      const camera::FrameView frame = view(i);
      const Clock::time_point t0 = Clock::now();
      processor.classifier().setFrame(frame);
      const rt::TrackingStats& stats = processor.tracker().track(processor.classifier());
      const Clock::time_point t1 = Clock::now();
      processor.lineDetector().detect(frame, processor.tracker().contours(), lines);
      const Clock::time_point t2 = Clock::now();
      result.initialSearches += stats.initialSearches;
      if (i == 0) continue;
      segment.push_back(microseconds(t1 - t0));
      whole.push_back(microseconds(t2 - t0));
      touched += stats.touchedFraction;
      touchedLines +=
          (stats.cellsClassified * cellSize * cellSize + processor.lineDetector().pixelsRead()) /
          pixels;
      overlap += stats.overlap;
      points += static_cast<double>(lines.points.size());
    }
    const int n = frameCount - 1;
    result.tracker = summarise(segment);
    result.trackerWhole = summarise(whole);
    result.touched = touched / n;
    result.touchedWithLines = touchedLines / n;
    result.overlap = overlap / n;
    result.linePoints = points / n;
  }

  // (a) CMVision-style, with the same line detector on its boundaries: classifying every cell
  // as CMVision does, and (a') skipping the don't-touch cells.
  for (const rt::FullFramePolicy policy :
       {rt::FullFramePolicy::kClassifyEveryCell, rt::FullFramePolicy::kSkipDontTouch}) {
    rt::FrameProcessor processor(sim.mirror, sim.table, params);  // for grid, mask, detectors
    rt::CmvisionSegmenter cmvision(processor.grid(), classes, processor.dontTouch(), policy);
    rt::LinePoints lines;
    std::vector<double> segment, whole;
    for (int i = 0; i < frameCount; ++i) {
      const camera::FrameView frame = view(i);
      const Clock::time_point t0 = Clock::now();
      processor.classifier().setFrame(frame);
      cmvision.segment(processor.classifier());
      const Clock::time_point t1 = Clock::now();
      processor.lineDetector().detect(frame, cmvision.contours(), lines);
      const Clock::time_point t2 = Clock::now();
      if (i == 0) continue;
      segment.push_back(microseconds(t1 - t0));
      whole.push_back(microseconds(t2 - t0));
    }
    if (policy == rt::FullFramePolicy::kClassifyEveryCell) {
      result.cmvision = summarise(segment);
      result.cmvisionWhole = summarise(whole);
    } else {
      result.cmvisionMasked = summarise(segment);
    }
  }

  // (b) OpenCV, classifying every cell.
  {
    rt::FrameProcessor processor(sim.mirror, sim.table, params);
    rt::OpenCvSegmenter opencv(processor.grid(), classes, processor.dontTouch());
    std::vector<double> segment;
    for (int i = 0; i < frameCount; ++i) {
      const Clock::time_point t0 = Clock::now();
      processor.classifier().setFrame(view(i));
      opencv.segment(processor.classifier());
      const Clock::time_point t1 = Clock::now();
      if (i > 0) segment.push_back(microseconds(t1 - t0));
    }
    result.opencv = summarise(segment);
  }

  // Agreement of the tracker's regions with baseline (a), frame by frame (not timed).
  {
    rt::FrameProcessor processor(sim.mirror, sim.table, params);
    rt::CmvisionSegmenter cmvision(processor.grid(), classes, processor.dontTouch());
    for (int i = 0; i < frameCount; ++i) {
      processor.classifier().setFrame(view(i));
      processor.tracker().track(processor.classifier());
      cmvision.segment(processor.classifier());
      const rt::Agreement agreement =
          rt::compareWithFullSegmentation(processor.tracker().visited(), cmvision);
      result.exactFrames += agreement.exact() ? 1 : 0;
      result.partialRegions += agreement.regionsPartial;
      result.staleCells += agreement.staleCells;
      result.untrackedRegions += agreement.regionsUntracked;
    }
  }
  return result;
}

std::string motionName(const Sequence& s) {
  char text[64];
  std::snprintf(text, sizeof text, "%.1f m/s %3.0f deg/s", s.speed, s.omegaDeg);
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Region tracker vs full-frame segmentation (CMVision-style, OpenCV) on rendered sequences."};
  int frames = 240;
  int cellSize = 4;
  bool quick = false;
  bool cold = false;
  std::string field = "msl";
  app.add_option("--frames", frames, "frames per sequence (30 Hz)")
      ->check(CLI::Range(10, 3000))
      ->capture_default_str();
  app.add_option("--cell-size", cellSize, "pixels per cell side: 1, 2, 4 or 8")
      ->check(CLI::IsMember({1, 2, 4, 8}))
      ->capture_default_str();
  app.add_option("--field", field, "field preset")->capture_default_str();
  app.add_flag("--quick", quick, "only the default sequence at both resolutions");
  app.add_flag(
      "--cold", cold,
      "process frames straight from memory (cache-cold) instead of a freshly delivered copy");
  CLI11_PARSE(app, argc, argv);

  std::vector<Sequence> sequences;
  for (const std::string cameraPreset : {"omni_sim", "omni_sim_640"}) {
    sequences.push_back({cameraPreset, 1.0, 90.0, "default"});
    if (quick) continue;
    const bool full = cameraPreset == "omni_sim";
    for (const double speed : full ? std::vector<double>{0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0}
                                   : std::vector<double>{0.0, 1.0, 3.0}) {
      sequences.push_back({cameraPreset, speed, 0.0, "translation"});
    }
    for (const double omega :
         full ? std::vector<double>{50, 100, 200, 300, 400} : std::vector<double>{50, 200, 400}) {
      sequences.push_back({cameraPreset, 0.0, omega, "rotation"});
    }
  }

  // One thread, as the comparison is meant: OpenCV would otherwise spread
  // connectedComponentsWithStats over its worker threads (and its time would depend on what
  // else runs on the machine).
  cv::setNumThreads(1);

  std::vector<Result> results;
  fieldline::config::runOrExit([&] {
    std::map<std::string, rt::SimCamera> cameras;
    for (const Sequence& s : sequences) {
      if (!cameras.count(s.camera)) cameras.emplace(s.camera, rt::SimCamera::load(s.camera, field));
      rt::SimCamera& sim = cameras.at(s.camera);
      results.push_back(run(sim, s, cellSize, frames, cold));
      const Result& r = results.back();
      std::fprintf(stderr, "done %s %dx%d %s\n", r.sequence.kind.c_str(), sim.mirror.width(),
                   sim.mirror.height(), motionName(r.sequence).c_str());
    }
  });

  std::printf(
      "region tracking benchmark: field %s, %d frames per sequence at 30 Hz, %dx%d cells, "
      "%s frames, times per frame in microseconds (median / p95), frame 0 excluded\n\n",
      field.c_str(), frames, cellSize, cellSize, cold ? "cache-cold" : "freshly delivered");
  std::printf(
      "| image | motion | tracker | tracker+lines | cmvision (a) | cmvision+lines | "
      "(a') skip mask | opencv (b) | a/tracker | a'/tracker | b/tracker | whole a/tracker | "
      "touched | touched+lines | overlap | initial searches | line points | exact frames | "
      "partial | stale cells | untracked |\n");
  std::printf(
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  const Result* defaultResult = nullptr;
  for (const Result& r : results) {
    const bool small = r.sequence.camera == "omni_sim";
    if (small && r.sequence.kind == "default") defaultResult = &r;
    std::printf(
        "| %s | %s | %.0f / %.0f | %.0f / %.0f | %.0f / %.0f | %.0f / %.0f | %.0f / %.0f | "
        "%.0f / %.0f | %.1f | %.1f | %.1f | %.1f | %.1f %% | %.1f %% | %.0f %% | %d / %d | %.0f | "
        "%d / %d | %d | %d | %.1f |\n",
        small ? "320x240" : "640x480", motionName(r.sequence).c_str(), r.tracker.median,
        r.tracker.p95, r.trackerWhole.median, r.trackerWhole.p95, r.cmvision.median, r.cmvision.p95,
        r.cmvisionWhole.median, r.cmvisionWhole.p95, r.cmvisionMasked.median, r.cmvisionMasked.p95,
        r.opencv.median, r.opencv.p95, r.cmvision.median / r.tracker.median,
        r.cmvisionMasked.median / r.tracker.median, r.opencv.median / r.tracker.median,
        r.cmvisionWhole.median / r.trackerWhole.median, 100 * r.touched, 100 * r.touchedWithLines,
        100 * r.overlap, r.initialSearches, r.frames, r.linePoints, r.exactFrames, r.frames,
        r.partialRegions, r.staleCells, static_cast<double>(r.untrackedRegions) / r.frames);
  }
  if (defaultResult != nullptr) {
    const Result& r = *defaultResult;
    std::printf("\nratio_vs_cmvision=%.2f ratio_vs_opencv=%.2f touched_fraction=%.3f\n",
                r.cmvision.median / r.tracker.median, r.opencv.median / r.tracker.median,
                r.touched);
  }
  return 0;
}
