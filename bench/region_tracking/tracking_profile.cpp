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
#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include "bench/region_tracking/bench_sequence.hpp"
#include "common/config/config.hpp"
#include "services/camera/realism.hpp"
#include "services/region_tracking/baselines.hpp"
#include "services/region_tracking/frame_processor.hpp"

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
  double other_tracked = 0;  // another tracked class (goal, ball, obstacle colours)
  double other = 0;          // unknown / untracked classes
  double next_to_mask = 0;   // touched cells with a don't-touch (or out-of-grid) neighbour
  // The least any exact shrink-and-grow classifies in a frame where nothing moved: the cells of
  // the tracked regions with a neighbour outside their region (shrink re-checks them) and the
  // touchable cells outside next to a region (grow must see they did not join it).
  double boundary_band = 0;
  double boundary_band_at_mask = 0;  // the part of the band next to the don't-touch mask
  double touchable_cells = 0;
  double cells = 0;
  double drops_processed = 0;
};

void addBreakdown(const rt::FrameProcessor& processor, rt::FrameCellClassifier& classifier,
                  Breakdown& b) {
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
    }
  }
}

// FNV-1a over the tracker's outputs of every frame: which class owns each cell, the contours
// (class, kind, area, every point in order) and the counts of TrackingStats.
class OutputDigest {
 public:
  void add(const rt::RegionTracker& tracker) {
    const rt::CellGrid& grid = tracker.grid();
    for (int y = 0; y < grid.height; ++y) {
      for (int x = 0; x < grid.width; ++x)
        mix(tracker.ownerOf(x, y));
    }
    const rt::ContourSet& contours = tracker.contours();
    for (const rt::Contour& c : contours.contours) {
      mix(c.class_id);
      mix(c.outer ? 1 : 0);
      mix(c.signed_cell_area);
      for (const rt::ContourPoint& p : contours.pointsOf(c)) {
        mix(p.x);
        mix(p.y);
      }
    }
    const rt::TrackingStats& s = tracker.stats();
    mix(s.cells_classified);
    for (const int n : s.classified_by)
      mix(n);
    mix(s.drops_processed);
    mix(s.cells_before);
    mix(s.cells_after_shrink);
    mix(s.cells_after_grow);
    mix(s.initial_searches);
    mix(s.contours);
  }
  // The line points of a frame: every position bit for bit, and the sequences.
  void add(const rt::LinePoints& lines) {
    mix(static_cast<std::int64_t>(lines.points.size()));
    for (const rt::LinePoint& p : lines.points) {
      for (const float f : {p.u, p.v, p.x, p.y})
        mix(std::bit_cast<std::uint32_t>(f));
    }
    mix(static_cast<std::int64_t>(lines.sequences.size()));
    for (const auto& [begin, end] : lines.sequences) {
      mix(begin);
      mix(end);
    }
  }
  std::uint64_t value() const { return hash_; }

 private:
  void mix(std::int64_t v) {
    for (int i = 0; i < 8; ++i) {
      hash_ = (hash_ ^ static_cast<std::uint8_t>(v >> (8 * i))) * 0x100000001b3ULL;
    }
  }
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

struct Options {
  std::string camera_preset = "omni_sim";
  std::string field = "msl";
  std::string method = "tracker";
  double speed = 1.0, omega_deg = 90.0;
  double blur_sigma = 0.0;
  int frames = 240, repeat = 1, line_repeat = 1;
  bool no_breakdown = false;
  bool digest = false;
  int max_seed_regions = -1;

  // The vision parameters of the run: the defaults, with --max-seed-regions.
  rt::VisionParams params() const {
    rt::VisionParams p = rt::defaultVisionParams();
    if (max_seed_regions >= 0) {
      for (rt::ClassTracking& c : p.tracker.classes)
        c.max_seed_regions = max_seed_regions;
    }
    return p;
  }

  void addTo(CLI::App& app) {
    app.add_option("--camera", camera_preset, "camera preset")->capture_default_str();
    app.add_option("--field", field, "field preset")->capture_default_str();
    app.add_option("--speed", speed, "m/s")->check(CLI::Range(0.0, 5.0))->capture_default_str();
    app.add_option("--omega", omega_deg, "deg/s")
        ->check(CLI::Range(0.0, 1000.0))
        ->capture_default_str();
    app.add_option("--blur", blur_sigma,
                   "optics blur of the rendered frames, px (0 = off; 1.2 is the calibration "
                   "evaluation's `blur` setting, where lines become ridges)")
        ->check(CLI::Range(0.0, 5.0))
        ->capture_default_str();
    app.add_option("--frames", frames, "frames (30 Hz)")
        ->check(CLI::Range(2, 3000))
        ->capture_default_str();
    app.add_option("--repeat", repeat, "runs over the sequence")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    app.add_option("--method", method, "tracker, whole (tracker + line points), cmvision, opencv")
        ->check(CLI::IsMember({"tracker", "whole", "cmvision", "opencv"}))
        ->capture_default_str();
    app.add_option("--line-repeat", line_repeat,
                   "with --method whole: line detector runs per frame (to profile it alone)")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    app.add_flag("--no-breakdown", no_breakdown, "skip the per-cell analysis (for callgrind)");
    app.add_flag("--digest", digest,
                 "print only a hash of the tracker's outputs over the sequence (owners, contours, "
                 "counts; to check that a change keeps them); with --method whole also one of "
                 "the line points and the pixels the line detector read");
    app.add_option("--max-seed-regions", max_seed_regions,
                   "seed only this many of the largest regions in an initial search (the seed: "
                   "10; 0: every region; default: the vision config's)")
        ->check(CLI::Range(0, 1000));
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
      addBreakdown(processor, processor.classifier(), breakdown);
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
  std::printf("\n| boundary band of the final regions | cells | of the image |\n|---|---|---|\n");
  row("band (a still frame classifies exactly these)", breakdown.boundary_band);
  row("(next to the don't-touch mask)", breakdown.boundary_band_at_mask);
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Profile the region tracker (or a baseline) on one rendered sequence."};
  Options options;
  options.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
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
