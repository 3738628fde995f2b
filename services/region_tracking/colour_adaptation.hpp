// Staying calibrated while the light changes (issue 12, part 2): the green and white classes of
// the colour table follow slow changes of the hall's light, estimated from the tracked green
// regions, within bounds around the calibration, and back to the calibration on demand.
//
// A change of light is a gain g on R, G and B: it scales luma and the chroma's distance from
// grey together. A colour cast (white balance off) adds a chroma offset that does not scale with
// the light, so the adapter works with differences to the carpet's own colour, which hold
// either way. It measures the median Y, U and V of the pixels in the cells the tracker holds as
// green, against the same statistics over the first frames after the start (or a reset), when
// the calibrated table fits by assumption; it follows them slowly (an exponential average, of
// log Y for the gain, so a robot driving over a lamp's bright spot does not swing the table),
// clamps the gain to [min_gain, max_gain] (bounded drift), and when the gain has moved by more
// than `rebuild_step` (or the carpet's chroma by more than `rebuild_chroma` levels) rebuilds the
// table: a cell (Y, U, V) is green or white when the calibrated table says so of
// (Y / g, U0 + (U - U1) / g, V0 + (V - V1) / g), (U0, V0) the carpet's chroma at the reference
// and (U1, V1) now; the other classes stay where the calibration put them. Classification stays
// one lookup per pixel; the table is rebuilt in place (the tracker's references stay valid),
// walking its 2^18 cells, only when the light has moved.
//
// Plain library: no LCM, no clock.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/config/config.hpp"
#include "services/region_tracking/region_tracker.hpp"

namespace fieldline::region_tracking {

struct ColourAdaptationParams {
  // Off: the table stays as calibrated.
  bool enabled = false;
  // Bounds of the light relative to the calibration.
  double min_gain = 0.4;
  double max_gain = 2.5;
  // Weight of each frame in the average of log(gain) (0.05: about 20 frames, 2/3 s at 30 fps).
  double smoothing = 0.05;
  // The table is rebuilt when the followed gain moved this far (relative) from the applied one,
  // or the carpet's followed chroma this many levels from the applied one.
  double rebuild_step = 0.04;
  double rebuild_chroma = 2.0;
  // Frames after the start or a reset whose statistic is the reference (the calibration light).
  int reference_frames = 5;
  // A frame with fewer green pixels sampled than this is not used (too little carpet in view).
  int min_samples = 150;
  // Every n-th cell in each direction is sampled (its centre pixel).
  int cell_stride = 2;
  // The carpet's median (Y, U, V) in the calibration frames (fieldline-colour-calibrate prints
  // it): the reference. Without it the first `reference_frames` frames after the start or a
  // reset are the reference, which is right only in the calibration's light.
  std::optional<std::array<double, 3>> reference;
};

// Reads the `adaptation` section of a vision preset: enabled, and optionally min_gain, max_gain,
// smoothing, rebuild_step, rebuild_chroma, reference_frames, min_samples, cell_stride,
// reference [y, u, v]. Throws
// config::Error.
ColourAdaptationParams loadColourAdaptationParams(const config::Node& node);

// The calibrated table as seen under light `gain`: green and white moved as described above,
// the other classes unchanged. `chroma_then` / `chroma_now`: the carpet's (U, V) at the
// reference and now; both (128, 128) scale the chroma around grey. Throws std::invalid_argument
// for a gain <= 0.
camera::ColourTable tableUnderLight(const camera::ColourTable& calibrated, double gain,
                                    std::array<double, 2> chroma_then = {128.0, 128.0},
                                    std::array<double, 2> chroma_now = {128.0, 128.0});

// Median Y, U and V of the centre pixels of every `cell_stride`-th cell the tracker owns as
// green; `samples` is how many pixels were read (the medians are -1 without any).
struct GreenStatistics {
  double y = -1, u = -1, v = -1;
  int samples = 0;
};
// `scratch` holds the samples; pass the same one every frame so nothing is allocated per frame.
using GreenSamples = std::array<std::vector<std::uint8_t>, 3>;
GreenStatistics trackedGreen(const camera::FrameView& frame, const RegionTracker& tracker,
                             int cell_stride, GreenSamples& scratch);

class ColourAdaptation {
 public:
  // `calibrated` is copied: the table to return to and to adapt from.
  ColourAdaptation(const camera::ColourTable& calibrated, const ColourAdaptationParams& params);

  // Feeds one tracked frame's statistics. Returns true when `table` (the one the tracker
  // classifies with) was rebuilt. Frames with too few samples are counted and skipped.
  bool observe(const GreenStatistics& green, camera::ColourTable& table);
  // The tracked frame itself (statistic from the tracker's green cells).
  bool observe(const camera::FrameView& frame, const RegionTracker& tracker,
               camera::ColourTable& table);
  // Back to the calibrated table; the next frames measure a new reference (unless the
  // parameters give it).
  void reset(camera::ColourTable& table);

  // The light followed (1 = the reference) and the one the table is built for.
  double gain() const;
  double appliedGain() const { return applied_gain_; }
  // True once the reference is measured.
  bool hasReference() const { return reference_count_ >= params_.reference_frames; }
  // True while the followed gain sits at one of its bounds.
  bool atBound() const { return at_bound_; }
  std::int64_t framesSkipped() const { return frames_skipped_; }
  std::int64_t rebuilds() const { return rebuilds_; }

 private:
  camera::ColourTable calibrated_;
  ColourAdaptationParams params_;
  double reference_log_y_ = 0;
  std::array<double, 2> reference_chroma_{0, 0};
  int reference_count_ = 0;
  double log_gain_ = 0;
  std::array<double, 2> chroma_{128, 128};
  double applied_gain_ = 1.0;
  std::array<double, 2> applied_chroma_{128, 128};
  bool at_bound_ = false;
  std::int64_t frames_skipped_ = 0;
  std::int64_t rebuilds_ = 0;
  GreenSamples samples_;  // reused by observe(frame, ...)

  void seedReference();
};

}  // namespace fieldline::region_tracking
