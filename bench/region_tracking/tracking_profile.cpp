// fieldline-profile-tracking: where the region tracker's work goes on one rendered sequence.
//
// Runs one method over the sequence (for `valgrind --tool=callgrind`, which counts instructions
// and so is repeatable on a shared machine) and, for the tracker, breaks the cells it classifies
// per frame down by why they were classified (TouchReason) and by what they are: green cells on
// a tracked region's boundary, cells of other classes, cells next to the don't-touch mask.
//
//   fieldline-profile-tracking                      # breakdown, default sequence
//   valgrind --tool=callgrind --toggle-collect="*RegionTracker::track*"
//       fieldline-profile-tracking --method tracker --no-breakdown   (one command line)
//   valgrind --tool=callgrind --toggle-collect="*LineDetector::detect*"
//       fieldline-profile-tracking --method whole --no-breakdown     (the line detector)
//   perf stat fieldline-profile-tracking --method whole --no-breakdown --line-repeat 400
//       (the detector run 400 times per frame, so that it dominates the counters)
//   fieldline-profile-tracking --digest              # one hash of everything the tracker output
//       (owners, contours, counts of every frame): equal before and after a speed change
//   fieldline-profile-tracking --digest --method whole   # also a hash of the line points
//       (every point's image and floor position bit for bit, the sequences) and the pixels the
//       line detector read: equal before and after a speed change of the line detector
//       (--blur 1.2 renders the frames through the optics blur, where the ridge rule finds lines)
//   fieldline-profile-tracking --mask-edge-every 2 --line-diff
//       the line points of the vision config with tracker.mask_edge_every 2 against the same
//       config with 1 (exact) on the same frames: points missing and extra, per frame, by range
#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bench/region_tracking/bench_sequence.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/geometry/geometry.hpp"
#include "services/camera/realism.hpp"
#include "services/feature_recognition/recognizer.hpp"
#include "services/region_tracking/baselines.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tests/support/output_digest.hpp"

namespace cli = fieldline::cli;
namespace rt = fieldline::region_tracking;
namespace camera = fieldline::camera;

namespace {

constexpr std::array<const char*, rt::kTouchReasonCount> kReasonNames = {
    "shrink", "grow", "seed (parent boundary)", "view edge", "initial search", "inside parent"};

struct Breakdown {
  std::array<double, rt::kTouchReasonCount> by_reason{};
  double touched = 0;
  // What the touched cells are in this frame.
  double green_owned = 0;      // green, in a tracked green region at the end of the frame
  double green_untracked = 0;  // green but not tracked
  double white = 0;
  double other_tracked = 0;       // another tracked class (goal, ball, obstacle colours)
  double other = 0;               // unknown / untracked classes
  double next_to_mask = 0;        // touched cells with a don't-touch (or out-of-grid) neighbour
  double next_to_mask_inner = 0;  // of those, at the inner edge (the robot's body)
  // The least any exact shrink-and-grow classifies in a frame where nothing moved: the cells of
  // the tracked regions with a neighbour outside their region (shrink re-checks them) and the
  // touchable cells outside next to a region (grow must see they did not join it).
  double boundary_band = 0;
  double boundary_band_at_mask = 0;   // the part of the band next to the don't-touch mask
  double boundary_band_at_inner = 0;  // of that, at the inner edge (rt::MaskEdge::kInner)
  double touchable_cells = 0;
  double cells = 0;
  double drops_processed = 0;
};

void addBreakdown(const rt::FrameProcessor& processor, rt::FrameCellClassifier& classifier,
                  const std::vector<rt::MaskEdge>& edges, Breakdown& b) {
  const rt::RegionTracker& tracker = processor.tracker();
  const rt::CellGrid& grid = processor.grid();
  const std::vector<std::uint8_t>& mask = processor.dontTouch();
  const rt::ClassId green = rt::classIdOf(camera::ColourClass::kGreen);
  const rt::ClassId white = rt::classIdOf(camera::ColourClass::kWhite);
  const rt::TrackingStats& stats = tracker.stats();
  for (int r = 0; r < rt::kTouchReasonCount; ++r)
    b.by_reason[r] += stats.classified_by[r];
  b.touched += stats.cells_classified;
  b.drops_processed += stats.drops_processed;
  std::array<bool, 256> tracked{};
  for (const rt::ClassTracking& t : tracker.config().classes)
    tracked[t.class_id] = true;
  auto blocked = [&](int x, int y) { return !grid.contains(x, y) || mask[grid.index(x, y)]; };
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      if (!mask[grid.index(x, y)]) ++b.touchable_cells;
      ++b.cells;
      const bool atMask =
          blocked(x - 1, y) || blocked(x + 1, y) || blocked(x, y - 1) || blocked(x, y + 1);
      if (!mask[grid.index(x, y)]) {
        const rt::ClassId self = tracker.ownerOf(x, y);
        bool band = false;
        const int dx[4] = {0, 1, 0, -1}, dy[4] = {-1, 0, 1, 0};
        for (int side = 0; side < 4 && !band; ++side) {
          const int nx = x + dx[side], ny = y + dy[side];
          const rt::ClassId other = blocked(nx, ny) ? rt::kNoClass : tracker.ownerOf(nx, ny);
          // A region cell next to anything else, or an outside cell next to a region.
          band = self != rt::kNoClass ? other != self || blocked(nx, ny) : other != rt::kNoClass;
        }
        if (band) {
          ++b.boundary_band;
          if (atMask) ++b.boundary_band_at_mask;
          if (edges[grid.index(x, y)] == rt::MaskEdge::kInner) ++b.boundary_band_at_inner;
        }
      }
      if (!tracker.classifiedInLastFrame(x, y)) continue;
      const rt::ClassId c = classifier.classify(x, y);
      const rt::ClassId owner = tracker.ownerOf(x, y);
      if (c == green) {
        (owner == green ? b.green_owned : b.green_untracked) += 1;
      } else if (c == white) {
        ++b.white;
      } else if (tracked[c]) {
        ++b.other_tracked;
      } else {
        ++b.other;
      }
      if (atMask) ++b.next_to_mask;
      if (edges[grid.index(x, y)] == rt::MaskEdge::kInner) ++b.next_to_mask_inner;
    }
  }
}

using rt::OutputDigest;

struct Options {
  std::string camera_preset = "omni_sim";
  std::string field = "msl";
  std::string method = "tracker";
  double speed = 1.0, omega_deg = 90.0;
  double blur_sigma = 0.0;
  int frames = 240, repeat = 1, line_repeat = 1;
  bool no_breakdown = false;
  bool digest = false;
  bool line_diff = false;
  bool phase_shift = false;
  int max_seed_regions = -1;
  int mask_edge_every = 0;
  int mask_edge_inner = -1;
  std::string vision_config;

  // The vision parameters of the run: the defaults (or --vision-config), with
  // --max-seed-regions, --mask-edge-every and --mask-edge-inner.
  rt::VisionParams params() const {
    rt::VisionParams p =
        vision_config.empty()
            ? rt::defaultVisionParams()
            : rt::loadVisionParams(fieldline::config::Node::loadFile(vision_config));
    if (max_seed_regions >= 0) {
      for (rt::ClassTracking& c : p.tracker.classes)
        c.max_seed_regions = max_seed_regions;
    }
    if (mask_edge_every > 0) p.tracker.mask_edge_every = mask_edge_every;
    if (mask_edge_inner >= 0) p.tracker.mask_edge_inner = mask_edge_inner != 0;
    return p;
  }

  void addTo(cli::App& app) {
    app.add_option("--camera", camera_preset, "camera preset")->capture_default_str();
    app.add_option("--field", field, "field preset")->capture_default_str();
    app.add_option("--speed", speed, "m/s")->check(cli::Range(0.0, 5.0))->capture_default_str();
    app.add_option("--omega", omega_deg, "deg/s")
        ->check(cli::Range(0.0, 1000.0))
        ->capture_default_str();
    app.add_option("--blur", blur_sigma,
                   "optics blur of the rendered frames, px (0 = off; 1.2 is the calibration "
                   "evaluation's `blur` setting, where lines become ridges)")
        ->check(cli::Range(0.0, 5.0))
        ->capture_default_str();
    app.add_option("--frames", frames, "frames (30 Hz)")
        ->check(cli::Range(2, 3000))
        ->capture_default_str();
    app.add_option("--repeat", repeat, "runs over the sequence")
        ->check(cli::Range(1, 100))
        ->capture_default_str();
    app.add_option("--method", method, "tracker, whole (tracker + line points), cmvision, opencv")
        ->check(cli::IsMember({"tracker", "whole", "cmvision", "opencv"}))
        ->capture_default_str();
    app.add_option("--line-repeat", line_repeat,
                   "with --method whole: line detector runs per frame (to profile it alone)")
        ->check(cli::Range(1, 1000))
        ->capture_default_str();
    app.add_flag("--no-breakdown", no_breakdown, "skip the per-cell analysis (for callgrind)");
    app.add_flag("--digest", digest,
                 "print only a hash of the tracker's outputs over the sequence (owners, contours, "
                 "counts; to check that a change keeps them); with --method whole also one of "
                 "the line points and the pixels the line detector read");
    app.add_option("--max-seed-regions", max_seed_regions,
                   "seed only this many of the largest regions in an initial search (the seed: "
                   "10; 0: every region; default: the vision config's)")
        ->check(cli::Range(0, 1000));
    app.add_option("--vision-config", vision_config,
                   "vision parameters (services/region_tracking/vision_default.yaml format); "
                   "default: the built-in defaults");
    app.add_option("--mask-edge-every", mask_edge_every,
                   "classify the cells next to the don't-touch mask every n-th frame "
                   "(tracker.mask_edge_every; 1: every frame, exact; default: the config's)")
        ->check(cli::Range(1, 16));
    app.add_option("--mask-edge-inner", mask_edge_inner,
                   "1: the cadence also at the inner edge (the robot's body), 0: the outer rim "
                   "only (tracker.mask_edge_inner; default: the config's)")
        ->check(cli::Range(0, 1));
    app.add_flag("--line-diff", line_diff,
                 "compare the line points with those of the same config at mask_edge_every 1 "
                 "on the same frames");
    app.add_flag("--phase-shift", phase_shift,
                 "with --line-diff: the tested tracker sees the first frame twice, so its rim "
                 "cells are due in the other frames (keep --frames below the re-initialisation "
                 "period, 300)");
  }
};

using Sequence = std::vector<std::vector<std::uint8_t>>;

// What --digest prints: hashes of the tracker's and the line detector's outputs of every frame.
struct Digests {
  OutputDigest tracker;
  OutputDigest lines;
  long long line_pixels_read = 0;
  int line_frames = 0;
};

// Runs the chosen method over the sequence (`repeat` times); for the tracker, sums the breakdown
// of every frame but the first (the initial search). Returns the number of frames summed.
int runMethod(const Options& options, rt::SimCamera& sim, const Sequence& sequence,
              Breakdown& breakdown, Digests& digests) {
  const rt::VisionParams params = options.params();
  std::vector<rt::ClassId> classes;
  for (const rt::ClassTracking& c : params.tracker.classes)
    classes.push_back(c.class_id);
  std::vector<std::uint8_t> delivered(sequence[0].size());
  rt::FrameProcessor processor(sim.mirror, sim.table, params);
  rt::CmvisionSegmenter cmvision(processor.grid(), classes, processor.dontTouch());
  rt::OpenCvSegmenter opencv(processor.grid(), classes, processor.dontTouch());
  rt::LinePoints lines;
  const std::vector<rt::MaskEdge> edges = rt::maskEdges(processor.grid(), processor.dontTouch());
  int measured = 0;
  for (int run = 0; run < options.repeat; ++run) {
    for (int i = 0; i < options.frames; ++i) {
      std::copy(sequence[i].begin(), sequence[i].end(), delivered.begin());
      const camera::FrameView frame = sim.renderer->view(delivered);
      processor.classifier().setFrame(frame);
      if (options.method == "cmvision") {
        cmvision.segment(processor.classifier());
        continue;
      }
      if (options.method == "opencv") {
        opencv.segment(processor.classifier());
        continue;
      }
      processor.tracker().track(processor.classifier());
      if (options.method == "whole") {
        for (int k = 0; k < options.line_repeat; ++k)
          processor.lineDetector().detect(frame, processor.tracker().contours(), lines);
        if (options.digest) {
          digests.lines.add(lines);
          digests.line_pixels_read += processor.lineDetector().pixelsRead();
          ++digests.line_frames;
        }
      }
      if (options.digest) digests.tracker.add(processor.tracker());
      if (options.no_breakdown || options.digest || i == 0) continue;
      addBreakdown(processor, processor.classifier(), edges, breakdown);
      ++measured;
    }
  }
  return measured;
}

void printBreakdown(const Options& options, const Breakdown& breakdown, int measured) {
  const double n = measured;
  const double cells = breakdown.cells / n;
  auto row = [&](const char* name, double total) {
    std::printf("| %s | %.1f | %.2f %% |\n", name, total / n, 100.0 * total / n / cells);
  };
  std::printf(
      "%s, %.1f m/s %.0f deg/s, %d frames, %.0f cells (%.0f touchable): cells "
      "classified per frame (mean over frames 1..%d)\n\n",
      options.camera_preset.c_str(), options.speed, options.omega_deg, options.frames, cells,
      breakdown.touchable_cells / n, options.frames - 1);
  std::printf("| reason | cells | of the image |\n|---|---|---|\n");
  for (int r = 0; r < rt::kTouchReasonCount; ++r)
    row(kReasonNames[r], breakdown.by_reason[r]);
  row("**all**", breakdown.touched);
  std::printf("\n| touched cell is | cells | of the image |\n|---|---|---|\n");
  row("green, tracked", breakdown.green_owned);
  row("green, untracked", breakdown.green_untracked);
  row("white", breakdown.white);
  row("another tracked class", breakdown.other_tracked);
  row("other (unknown, untracked class)", breakdown.other);
  row("(next to the don't-touch mask)", breakdown.next_to_mask);
  row("(of those, at the inner edge: the robot's body)", breakdown.next_to_mask_inner);
  std::printf("\n| boundary band of the final regions | cells | of the image |\n|---|---|---|\n");
  row("band (a still frame classifies exactly these)", breakdown.boundary_band);
  row("(next to the don't-touch mask)", breakdown.boundary_band_at_mask);
  row("(of those, at the inner edge: the robot's body)", breakdown.boundary_band_at_inner);
  std::printf("\ndrops processed per frame: %.0f\n", breakdown.drops_processed / n);
}

// The bound on the ratio: the tracker must at least classify the cells it touches, (a) must at
// least classify every cell. Timed here in one process, frame by frame, medians.
void printTimes(const Options& options, rt::SimCamera& sim, const Sequence& sequence) {
  using Clock = std::chrono::steady_clock;
  auto micro = [](Clock::duration d) {
    return std::chrono::duration<double, std::micro>(d).count();
  };
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  std::vector<std::uint8_t> delivered(sequence[0].size());
  rt::FrameProcessor timed(sim.mirror, sim.table, options.params());
  rt::FrameCellClassifier& classifier = timed.classifier();
  const rt::CellGrid& grid = timed.grid();
  std::vector<rt::Cell> touched_cells;
  std::vector<rt::ClassId> row_classes(grid.width);
  std::vector<double> track_times, touched_times, all_times, line_times, line_again_times;
  rt::LinePoints timed_lines;
  volatile unsigned sink = 0;
  for (int i = 0; i < options.frames; ++i) {
    std::copy(sequence[i].begin(), sequence[i].end(), delivered.begin());
    classifier.setFrame(sim.renderer->view(delivered));
    const Clock::time_point t0 = Clock::now();
    timed.tracker().track(classifier);
    const Clock::time_point t1 = Clock::now();
    timed.lineDetector().detect(sim.renderer->view(delivered), timed.tracker().contours(),
                                timed_lines);
    const Clock::time_point t_lines = Clock::now();
    timed.lineDetector().detect(sim.renderer->view(delivered), timed.tracker().contours(),
                                timed_lines);
    const Clock::time_point t_lines_again = Clock::now();
    touched_cells.clear();
    for (int y = 0; y < grid.height; ++y) {
      for (int x = 0; x < grid.width; ++x) {
        if (timed.tracker().classifiedInLastFrame(x, y)) {
          touched_cells.push_back({static_cast<std::int16_t>(x), static_cast<std::int16_t>(y)});
        }
      }
    }
    // Same frame, freshly delivered again so both start from the same cache state.
    std::copy(sequence[i].begin(), sequence[i].end(), delivered.begin());
    const Clock::time_point t2 = Clock::now();
    unsigned acc = 0;
    for (const rt::Cell c : touched_cells)
      acc += classifier.classify(c.x, c.y);
    const Clock::time_point t3 = Clock::now();
    std::copy(sequence[i].begin(), sequence[i].end(), delivered.begin());
    const Clock::time_point t4 = Clock::now();
    for (int y = 0; y < grid.height; ++y) {
      classifier.classifyRow(y, 0, row_classes);
      acc += row_classes[0];
    }
    const Clock::time_point t5 = Clock::now();
    sink = sink + acc;
    if (i == 0) continue;
    track_times.push_back(micro(t1 - t0));
    line_times.push_back(micro(t_lines - t1));
    line_again_times.push_back(micro(t_lines_again - t_lines));
    touched_times.push_back(micro(t3 - t2));
    all_times.push_back(micro(t5 - t4));
  }
  std::printf("\n| per frame, median | us |\n|---|---|\n");
  std::printf("| tracker (track: segmentation + boundaries) | %.1f |\n", median(track_times));
  std::printf("| line points on the tracker's boundaries (right after track) | %.1f |\n",
              median(line_times));
  std::printf("| the same again (frame and tables now cached) | %.1f |\n",
              median(line_again_times));
  std::printf("| classifying only the cells the tracker touched (raster order) | %.1f |\n",
              median(touched_times));
  std::printf("| classifying every cell (what (a) and (b) must do at least) | %.1f |\n",
              median(all_times));
}

constexpr std::array<double, 2> kTolerancePx = {1.0, 5.0};
constexpr std::array<double, 4> kRangeLimits = {2.0, 4.0, 6.0, 1e9};  // m
constexpr std::array<int, 4> kRimLimits = {2, 4, 8, 1 << 30};         // cells
constexpr int kFeatureKinds = 7;

// Unmatched points of one tolerance (missing: in the exact run only; extra: in the tested only).
struct UnmatchedCount {
  long long missing = 0, extra = 0;
  int max_missing = 0, max_extra = 0;
  std::array<long long, 4> missing_by_range{}, extra_by_range{};
  std::array<long long, 4> missing_by_rim{}, extra_by_rim{};
};

int rangeBin(const rt::LinePoint& p) {
  const double range = std::hypot(p.x, p.y);
  int bin = 0;
  while (range >= kRangeLimits[bin])
    ++bin;
  return bin;
}

// How far each cell is from the outer rim, so that a point missing "at the rim" can be told
// from one further in.
class RimBins {
 public:
  explicit RimBins(const rt::FrameProcessor& processor)
      : grid_(processor.grid()),
        rim_steps_(rt::stepsFromOuterRim(grid_, rt::maskEdges(grid_, processor.dontTouch()))) {}

  int bin(const rt::LinePoint& p) const {
    const int x = std::clamp(static_cast<int>(p.u) / grid_.cell_size, 0, grid_.width - 1);
    const int y = std::clamp(static_cast<int>(p.v) / grid_.cell_size, 0, grid_.height - 1);
    const int steps = rim_steps_[grid_.index(x, y)];
    int bin = 0;
    while (steps >= kRimLimits[bin])
      ++bin;
    return bin;
  }

 private:
  const rt::CellGrid& grid_;
  const std::vector<int> rim_steps_;
};

// Points of `a` with no point of `b` within `tolerance` px: counted, by range and by cells
// from the outer rim.
int unmatched(const rt::LinePoints& a, const rt::LinePoints& b, double tolerance,
              const RimBins& rim, std::array<long long, 4>& byRange,
              std::array<long long, 4>& byRim) {
  int n = 0;
  for (const rt::LinePoint& p : a.points) {
    const bool found = std::any_of(b.points.begin(), b.points.end(), [&](const rt::LinePoint& q) {
      return std::hypot(p.u - q.u, p.v - q.v) <= tolerance;
    });
    if (!found) {
      ++n;
      ++byRange[rangeBin(p)];
      ++byRim[rim.bin(p)];
    }
  }
  return n;
}

bool identicalPoints(const rt::LinePoints& a, const rt::LinePoints& b) {
  return a.points.size() == b.points.size() &&
         std::equal(a.points.begin(), a.points.end(), b.points.begin(),
                    [](const rt::LinePoint& p, const rt::LinePoint& q) {
                      return p.u == q.u && p.v == q.v && p.x == q.x && p.y == q.y;
                    });
}

// Everything --line-diff counts over the frames; run 0 is the exact run, run 1 the tested one.
struct LineDiffTally {
  std::array<UnmatchedCount, 2> counts;
  long long exact_points = 0, tested_points = 0;
  int identical_frames = 0, frames = 0;
  long long exact_cells = 0, tested_cells = 0;
  // Against the field model (the true pose of each frame): each point's distance to the nearest
  // line centre; points further than 10 cm are wrong.
  std::array<std::vector<double>, 2> model_errors;
  std::array<long long, 2> wrong_points{};
  // What feature recognition makes of each run's points: features by kind, pose hypotheses
  // within 0.5 m and 10 deg of the true pose (or its twin across the centre) and the others
  // (false), as fieldline-eval-features counts them, but on the moving sequence.
  std::array<std::array<long long, kFeatureKinds>, 2> features_by_kind{};
  std::array<long long, 2> good_hypotheses{}, false_hypotheses{};
  std::array<int, 2> frames_with_good{};

  void addModelErrors(const fieldline::field::FieldModel& field, const rt::LinePoints& lines,
                      int run, const fieldline::geometry::Pose2& pose) {
    for (const rt::LinePoint& p : lines.points) {
      const double e = field.distance(fieldline::geometry::pointRobotToField(pose, {p.x, p.y}));
      model_errors[run].push_back(e);
      wrong_points[run] += e > 0.10 ? 1 : 0;
    }
  }

  void addFeatures(const fieldline::perception::FieldFeatures& features, int run,
                   const fieldline::geometry::Pose2& truth) {
    for (const auto& f : features.features)
      ++features_by_kind[run][std::clamp(static_cast<int>(f.kind), 0, kFeatureKinds - 1)];
    const fieldline::geometry::Pose2 twin{-truth.x, -truth.y,
                                          fieldline::geometry::normalizeAngle(truth.phi + M_PI)};
    bool good = false;
    for (const auto& h : features.hypotheses) {
      bool near = false;
      for (const fieldline::geometry::Pose2& t : {truth, twin}) {
        near = near ||
               (std::hypot(h.pose.x - t.x, h.pose.y - t.y) <= 0.5 &&
                std::abs(fieldline::geometry::angleDiff(h.pose.phi, t.phi)) <= 10.0 * M_PI / 180.0);
      }
      (near ? good_hypotheses : false_hypotheses)[run] += 1;
      good = good || near;
    }
    frames_with_good[run] += good ? 1 : 0;
  }

  void addUnmatched(const rt::LinePoints& exactLines, const rt::LinePoints& testedLines,
                    const RimBins& rim) {
    for (std::size_t t = 0; t < kTolerancePx.size(); ++t) {
      UnmatchedCount& c = counts[t];
      const int missing = unmatched(exactLines, testedLines, kTolerancePx[t], rim,
                                    c.missing_by_range, c.missing_by_rim);
      const int extra = unmatched(testedLines, exactLines, kTolerancePx[t], rim, c.extra_by_range,
                                  c.extra_by_rim);
      c.missing += missing;
      c.extra += extra;
      c.max_missing = std::max(c.max_missing, missing);
      c.max_extra = std::max(c.max_extra, extra);
    }
  }
};

void printLineDiffSummary(const Options& options, const rt::VisionParams& testedParams,
                          LineDiffTally& tally) {
  const double n = tally.frames;
  std::printf(
      "%s, %.1f m/s %.0f deg/s, %d frames: line points with mask_edge_every %d (inner edge "
      "%s) against 1\n\n",
      options.camera_preset.c_str(), options.speed, options.omega_deg, tally.frames,
      testedParams.tracker.mask_edge_every, testedParams.tracker.mask_edge_inner ? "too" : "not");
  std::printf("cells classified per frame: %.1f exact, %.1f tested\n", tally.exact_cells / n,
              tally.tested_cells / n);
  std::printf(
      "line points per frame: %.1f exact, %.1f tested; frames with identical points: %d\n\n",
      tally.exact_points / n, tally.tested_points / n, tally.identical_frames);
  for (std::vector<double>& e : tally.model_errors)
    std::sort(e.begin(), e.end());
  auto quantile = [](const std::vector<double>& v, double q) {
    return v.empty() ? 0.0 : v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
  };
  const auto& errors = tally.model_errors;
  std::printf(
      "distance to the model lines, exact / tested: median %.4f / %.4f m, p95 %.4f / %.4f m; "
      "points further than 10 cm per frame %.3f / %.3f\n\n",
      quantile(errors[0], 0.5), quantile(errors[1], 0.5), quantile(errors[0], 0.95),
      quantile(errors[1], 0.95), tally.wrong_points[0] / n, tally.wrong_points[1] / n);
  const auto& kinds = tally.features_by_kind;
  std::printf(
      "features, exact / tested: centre circles %lld / %lld, penalty corners %lld / %lld, field "
      "corners %lld / %lld, T junctions %lld / %lld, straight lines %lld / %lld; frames with a "
      "correct pose hypothesis %d / %d; hypotheses correct %lld / %lld, false %lld / %lld\n\n",
      kinds[0][1], kinds[1][1], kinds[0][2], kinds[1][2], kinds[0][3], kinds[1][3], kinds[0][4],
      kinds[1][4], kinds[0][5], kinds[1][5], tally.frames_with_good[0], tally.frames_with_good[1],
      tally.good_hypotheses[0], tally.good_hypotheses[1], tally.false_hypotheses[0],
      tally.false_hypotheses[1]);
}

void printLineDiffTables(const LineDiffTally& tally) {
  const double n = tally.frames;
  std::printf(
      "| tolerance | missing per frame (max) | extra per frame (max) | missing by range <2 / 2-4 / "
      "4-6 / >6 m | extra by range |\n|---|---|---|---|---|\n");
  for (std::size_t t = 0; t < kTolerancePx.size(); ++t) {
    const UnmatchedCount& c = tally.counts[t];
    std::printf(
        "| %.0f px | %.3f (%d) | %.3f (%d) | %lld / %lld / %lld / %lld | %lld / %lld / "
        "%lld / %lld |\n",
        kTolerancePx[t], c.missing / n, c.max_missing, c.extra / n, c.max_extra,
        c.missing_by_range[0], c.missing_by_range[1], c.missing_by_range[2], c.missing_by_range[3],
        c.extra_by_range[0], c.extra_by_range[1], c.extra_by_range[2], c.extra_by_range[3]);
  }
  std::printf(
      "\n| tolerance | missing by cells from the outer rim 0-1 / 2-3 / 4-7 / 8+ | extra by cells "
      "from the rim |\n|---|---|---|\n");
  for (std::size_t t = 0; t < kTolerancePx.size(); ++t) {
    const UnmatchedCount& c = tally.counts[t];
    std::printf("| %.0f px | %lld / %lld / %lld / %lld | %lld / %lld / %lld / %lld |\n",
                kTolerancePx[t], c.missing_by_rim[0], c.missing_by_rim[1], c.missing_by_rim[2],
                c.missing_by_rim[3], c.extra_by_rim[0], c.extra_by_rim[1], c.extra_by_rim[2],
                c.extra_by_rim[3]);
  }
}

// --line-diff: the line points of the options' params (the tested cadence) against the same
// params with mask_edge_every 1 (exact), on the same frames, each processor tracking on its own.
// A point is missing when the exact run has it and the tested one has no point within the
// tolerance in the image (extra: the other way round); 1 px is the same point, 5 px allows for a
// sample taken one cell corner further along the same line (the sampling follows the contour
// from its start, which moves when the contour changes anywhere).
void printLineDiff(const Options& options, rt::SimCamera& sim, const Sequence& sequence) {
  rt::VisionParams exactParams = options.params();
  exactParams.tracker.mask_edge_every = 1;
  const rt::VisionParams testedParams = options.params();
  rt::FrameProcessor exact(sim.mirror, sim.table, exactParams);
  rt::FrameProcessor tested(sim.mirror, sim.table, testedParams);
  std::vector<std::uint8_t> delivered(sequence[0].size());
  rt::LinePoints exactLines, testedLines;
  const RimBins rim(exact);
  const std::vector<fieldline::geometry::Pose2> poses = rt::motionPoses(
      sim.field, {options.speed, options.omega_deg * std::numbers::pi / 180, 30.0}, options.frames);
  fieldline::feature_recognition::FeatureRecognizer recognizer(sim.field);
  fieldline::perception::FieldFeatures features;
  LineDiffTally tally;
  if (options.phase_shift) {
    std::copy(sequence[0].begin(), sequence[0].end(), delivered.begin());
    tested.classifier().setFrame(sim.renderer->view(delivered));
    tested.tracker().track(tested.classifier());
  }
  for (int i = 0; i < options.frames; ++i) {
    std::copy(sequence[i].begin(), sequence[i].end(), delivered.begin());
    const camera::FrameView frame = sim.renderer->view(delivered);
    for (rt::FrameProcessor* p : {&exact, &tested}) {
      p->classifier().setFrame(frame);
      p->tracker().track(p->classifier());
    }
    exact.lineDetector().detect(frame, exact.tracker().contours(), exactLines);
    tested.lineDetector().detect(frame, tested.tracker().contours(), testedLines);
    tally.addModelErrors(sim.field, exactLines, 0, poses[i]);
    tally.addModelErrors(sim.field, testedLines, 1, poses[i]);
    recognizer.recognize(exactLines, features);
    tally.addFeatures(features, 0, poses[i]);
    recognizer.recognize(testedLines, features);
    tally.addFeatures(features, 1, poses[i]);
    tally.exact_cells += exact.tracker().stats().cells_classified;
    tally.tested_cells += tested.tracker().stats().cells_classified;
    ++tally.frames;
    tally.exact_points += static_cast<long long>(exactLines.points.size());
    tally.tested_points += static_cast<long long>(testedLines.points.size());
    tally.identical_frames += identicalPoints(exactLines, testedLines) ? 1 : 0;
    tally.addUnmatched(exactLines, testedLines, rim);
  }
  printLineDiffSummary(options, testedParams, tally);
  printLineDiffTables(tally);
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{"Profile the region tracker (or a baseline) on one rendered sequence."};
  Options options;
  options.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    // --help prints and exits 0; bad arguments exit 2, as every fieldline executable should.
    return app.exit(e) == 0 ? 0 : 2;
  }

  cv::setNumThreads(1);  // one thread, as in fieldline-bench-tracking
  fieldline::config::runOrExit([&] {
    rt::SimCamera sim = rt::SimCamera::load(options.camera_preset, options.field);
    if (options.blur_sigma > 0.0) {
      camera::RealismParams realism;
      realism.blur_sigma = options.blur_sigma;
      sim.renderer->realism().setParams(realism);
    }
    const Sequence sequence =
        rt::bench::renderSequence(sim, options.speed, options.omega_deg, options.frames);
    if (options.line_diff) {
      printLineDiff(options, sim, sequence);
      return;
    }
    Breakdown breakdown;
    Digests digests;
    const int measured = runMethod(options, sim, sequence, breakdown, digests);
    if (options.digest) {
      std::printf("digest=%016llx\n", static_cast<unsigned long long>(digests.tracker.value()));
      if (digests.line_frames > 0) {
        std::printf("line_digest=%016llx line_pixels_read=%lld\n",
                    static_cast<unsigned long long>(digests.lines.value()),
                    digests.line_pixels_read);
      }
      return;
    }
    if (options.no_breakdown || measured == 0) return;
    printBreakdown(options, breakdown, measured);
    printTimes(options, sim, sequence);
  });
  return 0;
}
