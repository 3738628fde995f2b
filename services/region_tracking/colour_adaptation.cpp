#include "services/region_tracking/colour_adaptation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fieldline::region_tracking {
namespace {

using camera::ColourClass;

bool followsLight(ColourClass c) {
  return c == ColourClass::kGreen || c == ColourClass::kWhite;
}

std::uint8_t cellCentre(int cell) {
  constexpr int step = 1 << (8 - camera::ColourTable::kIndexBits);
  return static_cast<std::uint8_t>(cell * step + step / 2);
}

}  // namespace

ColourAdaptationParams loadColourAdaptationParams(const config::Node& node) {
  ColourAdaptationParams p;
  p.enabled = node.get<bool>("enabled");
  p.min_gain = node.getOr<double>("min_gain", p.min_gain, 0.05, 1.0);
  p.max_gain = node.getOr<double>("max_gain", p.max_gain, 1.0, 20.0);
  p.smoothing = node.getOr<double>("smoothing", p.smoothing, 1e-4, 1.0);
  p.rebuild_step = node.getOr<double>("rebuild_step", p.rebuild_step, 0.0, 1.0);
  p.rebuild_chroma = node.getOr<double>("rebuild_chroma", p.rebuild_chroma, 0.0, 255.0);
  p.reference_frames = node.getOr<int>("reference_frames", p.reference_frames, 1, 10000);
  p.min_samples = node.getOr<int>("min_samples", p.min_samples, 1, 1000000);
  p.cell_stride = node.getOr<int>("cell_stride", p.cell_stride, 1, 64);
  if (node.has("reference")) {
    const std::vector<double> r = node.getList<double>("reference", 3);
    if (!(r[0] > 0 && r[0] <= 255 && r[1] >= 0 && r[1] <= 255 && r[2] >= 0 && r[2] <= 255)) {
      node.fail("reference", "expected [y, u, v] with 0 < y <= 255, 0 <= u, v <= 255");
    }
    p.reference = std::array<double, 3>{r[0], r[1], r[2]};
  }
  node.rejectUnknownKeys();
  return p;
}

camera::ColourTable tableUnderLight(const camera::ColourTable& calibrated, double gain,
                                    std::array<double, 2> chroma_then,
                                    std::array<double, 2> chroma_now) {
  if (!(gain > 0) || !std::isfinite(gain)) {
    throw std::invalid_argument("tableUnderLight: the gain must be positive");
  }
  constexpr int n = 1 << camera::ColourTable::kIndexBits;
  const double inv = 1.0 / gain;
  // Level `level` now, relative to `now`, is `then` plus the difference divided by the gain.
  auto back = [inv](std::uint8_t level, double then, double now) {
    return static_cast<std::uint8_t>(std::clamp(std::lround(then + (level - now) * inv), 0L, 255L));
  };
  std::vector<ColourClass> cells(static_cast<std::size_t>(camera::ColourTable::kCells));
  for (int a = 0; a < n; ++a) {
    const std::uint8_t y = cellCentre(a);
    const std::uint8_t y0 = back(y, 0.0, 0.0);
    for (int b = 0; b < n; ++b) {
      const std::uint8_t u = cellCentre(b);
      const std::uint8_t u0 = back(u, chroma_then[0], chroma_now[0]);
      for (int c = 0; c < n; ++c) {
        const std::uint8_t v = cellCentre(c);
        const ColourClass moved =
            calibrated.classifyYuv(y0, u0, back(v, chroma_then[1], chroma_now[1]));
        const ColourClass here = calibrated.classifyYuv(y, u, v);
        cells[static_cast<std::size_t>(camera::ColourTable::index(y, u, v))] =
            followsLight(moved) ? moved : (followsLight(here) ? ColourClass::kUnknown : here);
      }
    }
  }
  return camera::ColourTable::fromLookup(std::move(cells));
}

GreenStatistics trackedGreen(const camera::FrameView& frame, const RegionTracker& tracker,
                             int cell_stride, GreenSamples& channels) {
  const CellGrid& grid = tracker.grid();
  const int s = grid.cell_size;
  const auto green = static_cast<ClassId>(ColourClass::kGreen);
  for (auto& channel : channels)
    channel.clear();
  for (int y = 0; y < grid.height; y += cell_stride) {
    for (int x = 0; x < grid.width; x += cell_stride) {
      if (tracker.ownerOf(x, y) != green) continue;
      const camera::Yuv c = camera::readYuv(frame, x * s + s / 2, y * s + s / 2);
      channels[0].push_back(c.y);
      channels[1].push_back(c.u);
      channels[2].push_back(c.v);
    }
  }
  GreenStatistics out;
  out.samples = static_cast<int>(channels[0].size());
  if (out.samples == 0) return out;
  std::array<double, 3> medians{};
  for (std::size_t k = 0; k < 3; ++k) {
    auto mid = channels[k].begin() + static_cast<std::ptrdiff_t>(channels[k].size() / 2);
    std::nth_element(channels[k].begin(), mid, channels[k].end());
    medians[k] = *mid;
  }
  out.y = medians[0];
  out.u = medians[1];
  out.v = medians[2];
  return out;
}

ColourAdaptation::ColourAdaptation(const camera::ColourTable& calibrated,
                                   const ColourAdaptationParams& params)
    : calibrated_(calibrated), params_(params) {
  if (!(params.min_gain > 0 && params.min_gain <= 1 && params.max_gain >= 1) ||
      !(params.smoothing > 0 && params.smoothing <= 1) || params.reference_frames < 1 ||
      params.cell_stride < 1 || params.rebuild_step < 0 || params.rebuild_chroma < 0) {
    throw std::invalid_argument(
        "ColourAdaptation: need 0 < min_gain <= 1 <= max_gain, 0 < smoothing <= 1, "
        "reference_frames >= 1, cell_stride >= 1, rebuild_step >= 0, rebuild_chroma >= 0");
  }
  if (params.reference && !((*params.reference)[0] > 0)) {
    throw std::invalid_argument("ColourAdaptation: the reference luma must be positive");
  }
  seedReference();
}

void ColourAdaptation::seedReference() {
  if (!params_.reference) return;
  const std::array<double, 3>& r = *params_.reference;
  reference_log_y_ = std::log(r[0]);
  reference_chroma_ = {r[1], r[2]};
  reference_count_ = params_.reference_frames;
  chroma_ = applied_chroma_ = reference_chroma_;
}

double ColourAdaptation::gain() const {
  return std::exp(log_gain_);
}

bool ColourAdaptation::observe(const GreenStatistics& green, camera::ColourTable& table) {
  if (green.samples < params_.min_samples || !(green.y > 0)) {
    ++frames_skipped_;
    return false;
  }
  if (!hasReference()) {
    // Measured under the calibrated table (after the start or a reset).
    reference_log_y_ += std::log(green.y);
    reference_chroma_[0] += green.u;
    reference_chroma_[1] += green.v;
    ++reference_count_;
    if (hasReference()) {
      reference_log_y_ /= reference_count_;
      reference_chroma_ = {reference_chroma_[0] / reference_count_,
                           reference_chroma_[1] / reference_count_};
      chroma_ = applied_chroma_ = reference_chroma_;
    }
    return false;
  }
  const double lo = std::log(params_.min_gain), hi = std::log(params_.max_gain);
  const double a = params_.smoothing;
  const double measured = std::clamp(std::log(green.y) - reference_log_y_, lo, hi);
  log_gain_ = std::clamp(log_gain_ + a * (measured - log_gain_), lo, hi);
  chroma_[0] += a * (green.u - chroma_[0]);
  chroma_[1] += a * (green.v - chroma_[1]);
  at_bound_ = log_gain_ <= lo + 1e-9 || log_gain_ >= hi - 1e-9;
  const bool gainMoved =
      std::abs(log_gain_ - std::log(applied_gain_)) > std::log1p(params_.rebuild_step);
  const bool chromaMoved = std::abs(chroma_[0] - applied_chroma_[0]) > params_.rebuild_chroma ||
                           std::abs(chroma_[1] - applied_chroma_[1]) > params_.rebuild_chroma;
  if (!gainMoved && !chromaMoved) return false;
  applied_gain_ = gain();
  applied_chroma_ = chroma_;
  table = tableUnderLight(calibrated_, applied_gain_, reference_chroma_, applied_chroma_);
  ++rebuilds_;
  return true;
}

bool ColourAdaptation::observe(const camera::FrameView& frame, const RegionTracker& tracker,
                               camera::ColourTable& table) {
  return observe(trackedGreen(frame, tracker, params_.cell_stride, samples_), table);
}

void ColourAdaptation::reset(camera::ColourTable& table) {
  table = calibrated_;
  reference_log_y_ = 0;
  reference_chroma_ = {0, 0};
  reference_count_ = 0;
  log_gain_ = 0;
  applied_gain_ = 1.0;
  chroma_ = applied_chroma_ = {128, 128};
  at_bound_ = false;
  seedReference();
}

}  // namespace fieldline::region_tracking
