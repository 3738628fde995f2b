// fieldline-bench-tracking: the region tracker against the two full-frame baselines on the same
// rendered sequences, in one process on one thread (seed table 3.1 and the comparison after it).
//
// For every sequence (robot translating or rotating at a fixed speed through the msl field, four
// other robots standing on it, a ball rolling along in view) the frames are rendered first and
// kept in memory; then each method runs over all of them and every frame is timed, in several
// rounds (a frame's time is its fastest round; see summarise):
//   tracker   grow/shrink tracking + boundaries            (+ line points: the "whole step")
//   (a)       CMVision-style: classify all cells, RLE, union-find, boundaries from the runs
//             (+ the same line points); (a') the same skipping the cells outside the mirror
//   (b)       OpenCV: histogram, then per class present a mask, connectedComponentsWithStats,
//             findContours
// All use the same cells (same size, same block classifier, same don't-touch mask, same classes).
// The first frame of each round (initial search) is left out of the times. The last line is, for
// the default sequence (1 m/s, 90 deg/s) at 320x240 (the lines before it, prefixed "640x480: "
// and "1280x960: ", the same at those sizes),
//   ratio_vs_cmvision=X ratio_vs_opencv=Y touched_fraction=Z whole_step_ratio=W
//   per_touched_cell_vs_baseline=V
// X, Y: median frame time of (a), (b) over the tracker's (without lines); Z: cells the tracker
// classified over all cells; W: (a)+lines over tracker+lines; V: the tracker's median time per
// cell it classified over (a)'s median time per cell of the grid (scene-independent: how much
// dearer a tracked cell is than a cell of a full pass). The line "scaling: ..." gives the whole
// step's (and the tracker's) median at each larger size over its median at the size below.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bench/region_tracking/bench_sequence.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "services/region_tracking/baselines.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace cli = fieldline::cli;
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

// `values` holds one time per frame for each round, round after round. Each frame's time is its
// fastest round: the work of a frame is the same in every round, so the fastest is the one the
// shared machine disturbed least. Median and p95 are then taken over the frames.
Summary summarise(const std::vector<double>& values, int rounds) {
  if (values.empty()) return {};
  const std::size_t frames = values.size() / rounds;
  std::vector<double> fastest(values.begin(), values.begin() + frames);
  for (int r = 1; r < rounds; ++r) {
    for (std::size_t i = 0; i < frames; ++i)
      fastest[i] = std::min(fastest[i], values[r * frames + i]);
  }
  std::sort(fastest.begin(), fastest.end());
  auto at = [&](double q) {
    return fastest[static_cast<std::size_t>(q * (fastest.size() - 1) + 0.5)];
  };
  return {at(0.5), at(0.95)};
}

struct Sequence {
  std::string camera;  // preset
  double speed;        // m/s
  double omega_deg;    // deg/s
  std::string kind;    // "translation", "rotation", "default"
};

struct Result {
  Sequence sequence;
  int width = 0, height = 0;  // image, px
  int cell_size = 0;
  int frames = 0;
  Summary tracker, tracker_whole, cmvision, cmvision_whole, cmvision_masked, opencv;
  double touched = 0, touched_with_lines = 0, overlap = 0;
  double touched_cells = 0;  // mean cells classified per frame
  int grid_cells = 0;
  int ball_frames = 0;  // frames in which the tracker holds an orange (ball) region
  int initial_searches = 0;
  double line_points = 0;
  // Agreement with baseline (a) after every tracked frame.
  int exact_frames = 0, partial_regions = 0, stale_cells = 0, untracked_regions = 0;
};

std::vector<rt::ClassId> trackedClasses(const rt::VisionParams& params) {
  std::vector<rt::ClassId> classes;
  for (const rt::ClassTracking& c : params.tracker.classes)
    classes.push_back(c.class_id);
  return classes;
}

enum class Order {
  kSequential,   // in a round, each method over all frames before the next
  kInterleaved,  // in a round, frame by frame, every method on each frame
};

rt::VisionParams benchVisionParams(int cell_size, int max_seed_regions,
                                   const std::string& vision_config) {
  rt::VisionParams params =
      vision_config.empty()
          ? rt::defaultVisionParams()
          : rt::loadVisionParams(fieldline::config::Node::loadFile(vision_config));
  params.tracker.cell_size = cell_size;
  if (max_seed_regions >= 0) {
    for (rt::ClassTracking& c : params.tracker.classes)
      c.max_seed_regions = max_seed_regions;
  }
  return params;
}

// The rendered frames of a sequence, handed to each method the way the node gets them: the LCM
// handler has just decoded (copied) the message, so the frame is in the cache. --cold reads the
// stored frames directly.
class FrameSource {
 public:
  FrameSource(rt::SimCamera& sim, const Sequence& sequence, int frameCount, bool coldFrames)
      : sim_(sim),
        frames_(rt::bench::renderSequence(sim, sequence.speed, sequence.omega_deg, frameCount)),
        delivered_(frames_[0].size()),
        cold_(coldFrames) {}

  camera::FrameView view(int i) {
    if (cold_) return sim_.renderer->view(frames_[i]);
    std::copy(frames_[i].begin(), frames_[i].end(), delivered_.begin());
    return sim_.renderer->view(delivered_);
  }

 private:
  rt::SimCamera& sim_;
  const std::vector<std::vector<std::uint8_t>> frames_;
  std::vector<std::uint8_t> delivered_;
  bool cold_;
};

// (a) CMVision-style, with the same line detector on its boundaries: classifying every cell
// as CMVision does; and (a') skipping the don't-touch cells (segmentation only).
struct FullFrame {
  rt::FrameProcessor processor;  // for the classifier and the line detector
  rt::CmvisionSegmenter cmvision;
  rt::LinePoints lines;
  std::vector<double> segment, whole;
};

// One timed run of the four methods over a sequence. Each method is one step per frame; all
// times are wall-clock times of one thread. The tracker's counts are taken in the first round.
class MethodRun {
 public:
  MethodRun(rt::SimCamera& sim, FrameSource& source, int cell_size, const rt::VisionParams& params)
      : source_(source),
        params_(params),
        classes_(trackedClasses(params)),
        cell_size_(cell_size),
        pixels_(static_cast<double>(sim.mirror.width()) * sim.mirror.height()),
        ball_class_(static_cast<rt::ClassId>(params.ball.colour)),
        tracking_(sim.mirror, sim.table, params),
        a_{rt::FrameProcessor(sim.mirror, sim.table, params),
           {tracking_.grid(), classes_, tracking_.dontTouch(),
            rt::FullFramePolicy::kClassifyEveryCell},
           {},
           {},
           {}},
        a_masked_{rt::FrameProcessor(sim.mirror, sim.table, params),
                  {tracking_.grid(), classes_, tracking_.dontTouch(),
                   rt::FullFramePolicy::kSkipDontTouch},
                  {},
                  {},
                  {}},
        opencv_processor_(sim.mirror, sim.table, params),
        opencv_(tracking_.grid(), classes_, tracking_.dontTouch()) {}

  // Several rounds over the sequence, the order of the methods rotating from round to round, so
  // that a slow spell of the shared machine does not hit one method alone. The tracker starts
  // afresh each round (frame 0 of every round is left out); its output is the same each round.
  void runRounds(int frameCount, int rounds, Order order, Result& result) {
    for (round_ = 0; round_ < rounds; ++round_) {
      tracking_.tracker() =
          rt::RegionTracker(tracking_.grid(), params_.tracker, tracking_.dontTouch());
      if (order == Order::kInterleaved) {
        for (int i = 0; i < frameCount; ++i) {
          for (int k = 0; k < kMethods; ++k)
            step((i + k + round_) % kMethods, i, result);
        }
      } else {
        for (int k = 0; k < kMethods; ++k) {
          for (int i = 0; i < frameCount; ++i)
            step((k + round_) % kMethods, i, result);
        }
      }
    }
  }

  void summariseInto(int frameCount, int rounds, Result& result) const {
    const int n = frameCount - 1;
    result.tracker = summarise(tracker_segment_, rounds);
    result.tracker_whole = summarise(tracker_whole_, rounds);
    result.touched = touched_ / n;
    result.touched_cells = cells_ / n;
    result.grid_cells = tracking_.grid().cellCount();
    result.touched_with_lines = touched_lines_ / n;
    result.overlap = overlap_ / n;
    result.line_points = points_ / n;
    result.cmvision = summarise(a_.segment, rounds);
    result.cmvision_whole = summarise(a_.whole, rounds);
    result.cmvision_masked = summarise(a_masked_.segment, rounds);
    result.opencv = summarise(opencv_segment_, rounds);
  }

 private:
  static constexpr int kMethods = 4;

  void step(int method, int i, Result& result) {
    switch (method) {
      case 0:
        trackerStep(i, result);
        break;
      case 1:
        cmvisionStep(a_, true, i);
        break;
      case 2:
        cmvisionStep(a_masked_, false, i);
        break;
      default:
        opencvStep(i);
        break;
    }
  }

  // Tracker (and line points on its boundaries).
  void trackerStep(int i, Result& result) {
    const camera::FrameView frame = source_.view(i);
    const Clock::time_point t0 = Clock::now();
    tracking_.classifier().setFrame(frame);
    const rt::TrackingStats& stats = tracking_.tracker().track(tracking_.classifier());
    const Clock::time_point t1 = Clock::now();
    tracking_.lineDetector().detect(frame, tracking_.tracker().contours(), tracker_lines_);
    const Clock::time_point t2 = Clock::now();
    if (round_ == 0) result.initial_searches += stats.initial_searches;
    if (i == 0) return;
    tracker_segment_.push_back(microseconds(t1 - t0));
    tracker_whole_.push_back(microseconds(t2 - t0));
    if (round_ > 0) return;
    touched_ += stats.touched_fraction;
    cells_ += stats.cells_classified;
    result.ball_frames += tracking_.tracker().regionCells(ball_class_) > 0 ? 1 : 0;
    touched_lines_ +=
        (stats.cells_classified * cell_size_ * cell_size_ + tracking_.lineDetector().pixelsRead()) /
        pixels_;
    overlap_ += stats.overlap;
    points_ += static_cast<double>(tracker_lines_.points.size());
  }

  void cmvisionStep(FullFrame& m, bool withLines, int i) {
    const camera::FrameView frame = source_.view(i);
    const Clock::time_point t0 = Clock::now();
    m.processor.classifier().setFrame(frame);
    m.cmvision.segment(m.processor.classifier());
    const Clock::time_point t1 = Clock::now();
    if (withLines) m.processor.lineDetector().detect(frame, m.cmvision.contours(), m.lines);
    const Clock::time_point t2 = Clock::now();
    if (i == 0) return;
    m.segment.push_back(microseconds(t1 - t0));
    m.whole.push_back(microseconds(t2 - t0));
  }

  // (b) OpenCV, classifying every cell, labelling only the classes present.
  void opencvStep(int i) {
    const camera::FrameView frame = source_.view(i);
    const Clock::time_point t0 = Clock::now();
    opencv_processor_.classifier().setFrame(frame);
    opencv_.segment(opencv_processor_.classifier());
    const Clock::time_point t1 = Clock::now();
    if (i > 0) opencv_segment_.push_back(microseconds(t1 - t0));
  }

  FrameSource& source_;
  const rt::VisionParams& params_;
  const std::vector<rt::ClassId> classes_;
  const int cell_size_;
  const double pixels_;
  const rt::ClassId ball_class_;
  int round_ = 0;

  rt::FrameProcessor tracking_;
  rt::LinePoints tracker_lines_;
  std::vector<double> tracker_segment_, tracker_whole_;
  double touched_ = 0, touched_lines_ = 0, overlap_ = 0, points_ = 0, cells_ = 0;

  FullFrame a_, a_masked_;

  rt::FrameProcessor opencv_processor_;
  rt::OpenCvSegmenter opencv_;
  std::vector<double> opencv_segment_;
};

// Agreement of the tracker's regions with baseline (a), frame by frame (not timed).
void countAgreement(rt::SimCamera& sim, FrameSource& source, int frameCount,
                    const rt::VisionParams& params, Result& result) {
  rt::FrameProcessor processor(sim.mirror, sim.table, params);
  rt::CmvisionSegmenter cmvision(processor.grid(), trackedClasses(params), processor.dontTouch());
  for (int i = 0; i < frameCount; ++i) {
    processor.classifier().setFrame(source.view(i));
    processor.tracker().track(processor.classifier());
    cmvision.segment(processor.classifier());
    const rt::Agreement agreement =
        rt::compareWithFullSegmentation(processor.tracker().visited(), cmvision);
    result.exact_frames += agreement.exact() ? 1 : 0;
    result.partial_regions += agreement.regions_partial;
    result.stale_cells += agreement.stale_cells;
    result.untracked_regions += agreement.regions_untracked;
  }
}

Result run(rt::SimCamera& sim, const Sequence& sequence, int cell_size, int frameCount, int rounds,
           bool coldFrames, Order order, int max_seed_regions, const std::string& vision_config) {
  Result result;
  result.sequence = sequence;
  result.width = sim.mirror.width();
  result.height = sim.mirror.height();
  result.cell_size = cell_size;
  result.frames = frameCount;

  FrameSource source(sim, sequence, frameCount, coldFrames);  // renders the sequence once
  const rt::VisionParams params = benchVisionParams(cell_size, max_seed_regions, vision_config);
  MethodRun methods(sim, source, cell_size, params);
  methods.runRounds(frameCount, rounds, order, result);
  methods.summariseInto(frameCount, rounds, result);
  countAgreement(sim, source, frameCount, params, result);
  return result;
}

// The tracker's time per cell it classified over (a)'s time per cell of the grid (medians of
// the times, mean of the touched cells).
double perTouchedCellVsBaseline(const Result& r) {
  return (r.tracker.median / r.touched_cells) / (r.cmvision.median / r.grid_cells);
}

std::string imageName(const Result& r) {
  return std::to_string(r.width) + "x" + std::to_string(r.height);
}

std::string motionName(const Sequence& s) {
  char text[64];
  std::snprintf(text, sizeof text, "%.1f m/s %3.0f deg/s", s.speed, s.omega_deg);
  return text;
}

struct Options {
  int frames = 240;
  int cell_size = 4;
  bool quick = false;
  bool cold = false;
  bool interleave = false;
  int rounds = 5;
  int max_seed_regions = -1;
  std::string vision_config;
  std::string field = "msl";

  void addTo(cli::App& app) {
    app.add_option("--frames", frames, "frames per sequence (30 Hz)")
        ->check(cli::Range(10, 3000))
        ->capture_default_str();
    app.add_option("--cell-size", cell_size, "pixels per cell side: 1, 2, 4 or 8")
        ->check(cli::IsMember({1, 2, 4, 8}))
        ->capture_default_str();
    app.add_option("--field", field, "field preset")->capture_default_str();
    app.add_flag("--quick", quick,
                 "only the default sequence at each size (320x240, 640x480, 1280x960)");
    app.add_flag(
        "--cold", cold,
        "process frames straight from memory (cache-cold) instead of a freshly delivered copy");
    app.add_option("--rounds", rounds,
                   "rounds over each sequence, the methods' order rotating; a frame's time is its "
                   "fastest round")
        ->check(cli::Range(1, 20))
        ->capture_default_str();
    app.add_option("--max-seed-regions", max_seed_regions,
                   "seed only this many of the largest regions in an initial search (the seed: "
                   "10; 0: every region; default: the vision config's)")
        ->check(cli::Range(0, 1000));
    app.add_option("--vision-config", vision_config,
                   "region tracking parameters (YAML, as fieldline-region-tracking's; default: the "
                   "built-in ones); --cell-size still applies")
        ->check(cli::ExistingFile);
    app.add_flag("--interleave", interleave,
                 "run the methods frame by frame instead of each over the whole sequence in turn "
                 "(each method's data then leaves the cache between its frames)");
  }
};

// The default sequence at each size; without --quick the translations and rotations (at 1280x960
// only the default sequence: its 240 frames alone hold 590 MB).
std::vector<Sequence> sequencesToRun(bool quick) {
  std::vector<Sequence> sequences;
  for (const std::string camera_preset : {"omni_sim", "omni_sim_640", "omni_sim_1280"}) {
    sequences.push_back({camera_preset, 1.0, 90.0, "default"});
    if (quick || camera_preset == "omni_sim_1280") continue;
    const bool full = camera_preset == "omni_sim";
    for (const double speed : full ? std::vector<double>{0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0}
                                   : std::vector<double>{0.0, 1.0, 3.0}) {
      sequences.push_back({camera_preset, speed, 0.0, "translation"});
    }
    for (const double omega :
         full ? std::vector<double>{50, 100, 200, 300, 400} : std::vector<double>{50, 200, 400}) {
      sequences.push_back({camera_preset, 0.0, omega, "rotation"});
    }
  }
  return sequences;
}

// The full table, then the summary lines of the default sequences (largest first, 320x240 last).
void printResults(const Options& options, const std::vector<Result>& results) {
  std::printf(
      "region tracking benchmark: field %s, %d frames per sequence at 30 Hz, %dx%d cells, "
      "%s frames, %d rounds with methods %s; times in microseconds: each frame's fastest round, "
      "median / p95 over the frames; frame 0 of each round excluded\n\n",
      options.field.c_str(), options.frames, options.cell_size, options.cell_size,
      options.cold ? "cache-cold" : "freshly delivered", options.rounds,
      options.interleave ? "interleaved frame by frame" : "one after another");
  std::printf(
      "| image | motion | tracker | tracker+lines | cmvision (a) | cmvision+lines | "
      "(a') skip mask | opencv (b) | a/tracker | a'/tracker | b/tracker | whole a/tracker | "
      "touched | touched+lines | per touched cell / (a) per cell | overlap | initial searches | "
      "line points | ball frames | exact frames | partial | stale cells | untracked |\n");
  std::printf(
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---"
      "|"
      "\n");
  // The default sequences, largest image first (320x240 last, the line tools read).
  std::vector<const Result*> default_results;
  for (const Result& r : results) {
    if (r.sequence.kind == "default") default_results.push_back(&r);
  }
  std::sort(default_results.begin(), default_results.end(),
            [](const Result* a, const Result* b) { return a->width > b->width; });
  for (const Result& r : results) {
    std::printf(
        "| %s | %s | %.0f / %.0f | %.0f / %.0f | %.0f / %.0f | %.0f / %.0f | %.0f / %.0f | "
        "%.0f / %.0f | %.1f | %.1f | %.1f | %.1f | %.1f %% | %.1f %% | %.1f | %.0f %% | %d / %d | "
        "%.0f | %d / %d | %d / %d | %d | %d | %.1f |\n",
        imageName(r).c_str(), motionName(r.sequence).c_str(), r.tracker.median, r.tracker.p95,
        r.tracker_whole.median, r.tracker_whole.p95, r.cmvision.median, r.cmvision.p95,
        r.cmvision_whole.median, r.cmvision_whole.p95, r.cmvision_masked.median,
        r.cmvision_masked.p95, r.opencv.median, r.opencv.p95, r.cmvision.median / r.tracker.median,
        r.cmvision_masked.median / r.tracker.median, r.opencv.median / r.tracker.median,
        r.cmvision_whole.median / r.tracker_whole.median, 100 * r.touched,
        100 * r.touched_with_lines, perTouchedCellVsBaseline(r), 100 * r.overlap,
        r.initial_searches, r.frames, r.line_points, r.ball_frames, r.frames - 1, r.exact_frames,
        r.frames, r.partial_regions, r.stale_cells,
        static_cast<double>(r.untracked_regions) / r.frames);
  }
  std::printf("\n");
  // The medians of the default sequences with a decimal, and the line detector's share of the
  // whole step on each side (the difference of the medians).
  for (const Result* r : default_results) {
    std::printf(
        "%s default: tracker %.1f us, tracker+lines %.1f us (lines %.1f), cmvision %.1f us, "
        "cmvision+lines %.1f us (lines %.1f)\n",
        imageName(*r).c_str(), r->tracker.median, r->tracker_whole.median,
        r->tracker_whole.median - r->tracker.median, r->cmvision.median, r->cmvision_whole.median,
        r->cmvision_whole.median - r->cmvision.median);
  }
  // Each size against the next smaller one (same process, same load): whole step and tracker.
  for (std::size_t i = 0; i + 1 < default_results.size(); ++i) {
    const Result& big = *default_results[i];
    const Result& small = *default_results[i + 1];
    std::printf("scaling: %s over %s: whole step %.2fx, tracker %.2fx, touched %.3f -> %.3f\n",
                imageName(big).c_str(), imageName(small).c_str(),
                big.tracker_whole.median / small.tracker_whole.median,
                big.tracker.median / small.tracker.median, small.touched, big.touched);
  }
  std::printf("\n");
  for (const Result* r : default_results) {
    std::printf(
        "%sratio_vs_cmvision=%.2f ratio_vs_opencv=%.2f touched_fraction=%.3f "
        "whole_step_ratio=%.2f per_touched_cell_vs_baseline=%.2f\n",
        r->width == 320 ? "" : (imageName(*r) + ": ").c_str(),
        r->cmvision.median / r->tracker.median, r->opencv.median / r->tracker.median, r->touched,
        r->cmvision_whole.median / r->tracker_whole.median, perTouchedCellVsBaseline(*r));
  }
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Region tracker vs full-frame segmentation (CMVision-style, OpenCV) on rendered sequences."};
  Options options;
  options.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    // --help prints and exits 0; bad arguments exit 2, as every fieldline executable should.
    return app.exit(e) == 0 ? 0 : 2;
  }
  const std::vector<Sequence> sequences = sequencesToRun(options.quick);
  // One thread, as the comparison is meant: OpenCV would otherwise spread
  // connectedComponentsWithStats over its worker threads (and its time would depend on what
  // else runs on the machine).
  cv::setNumThreads(1);

  std::vector<Result> results;
  fieldline::config::runOrExit([&] {
    std::map<std::string, rt::SimCamera> cameras;
    for (const Sequence& s : sequences) {
      if (!cameras.count(s.camera)) {
        cameras.emplace(s.camera, rt::SimCamera::load(s.camera, options.field));
      }
      rt::SimCamera& sim = cameras.at(s.camera);
      results.push_back(run(sim, s, options.cell_size, options.frames, options.rounds, options.cold,
                            options.interleave ? Order::kInterleaved : Order::kSequential,
                            options.max_seed_regions, options.vision_config));
      const Result& r = results.back();
      std::fprintf(stderr, "done %s %dx%d %s\n", r.sequence.kind.c_str(), sim.mirror.width(),
                   sim.mirror.height(), motionName(r.sequence).c_str());
    }
  });
  printResults(options, results);
  return 0;
}
