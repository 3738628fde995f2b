#include "services/region_tracking/vision_health.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace fieldline::region_tracking {

VisionHealthParams loadVisionHealthParams(const config::Node& n) {
  VisionHealthParams p;
  p.window_frames = n.getOr<int>("window_frames", p.window_frames, 1, 10000);
  p.min_green_fraction = n.getOr<double>("min_green_fraction", p.min_green_fraction, 0.0, 1.0);
  p.max_orange_fraction = n.getOr<double>("max_orange_fraction", p.max_orange_fraction, 0.0, 1.0);
  p.max_line_frames_without_points =
      n.getOr<int>("max_line_frames_without_points", p.max_line_frames_without_points, 1, 100000);
  p.max_search_fraction = n.getOr<double>("max_search_fraction", p.max_search_fraction, 0.0, 1.0);
  p.sample_stride = n.getOr<int>("sample_stride", p.sample_stride, 1, 64);
  n.rejectUnknownKeys();
  return p;
}

VisionHealth::VisionHealth(const camera::MirrorModel& mirror, const camera::ColourTable& table,
                           const VisionHealthParams& params)
    : table_(table), params_(params) {
  if (params_.window_frames < 1 || params_.sample_stride < 1 ||
      params_.max_line_frames_without_points < 1) {
    throw std::invalid_argument(
        "vision health: window_frames, sample_stride and max_line_frames_without_points must be "
        ">= 1");
  }
  const int s = params_.sample_stride;
  for (int v = s / 2; v < mirror.height(); v += s) {
    for (int u = s / 2; u < mirror.width(); u += s) {
      if (!mirror.dontTouch(u, v)) samples_.push_back({u, v});
    }
  }
  if (samples_.empty()) throw std::invalid_argument("vision health: no floor pixel to sample");
  window_.resize(static_cast<std::size_t>(params_.window_frames));
}

double VisionHealth::mean(float FrameFacts::*field) const {
  if (filled_ == 0) return 0.0;
  double sum = 0.0;
  for (std::size_t i = 0; i < filled_; ++i)
    sum += window_[i].*field;
  return sum / static_cast<double>(filled_);
}

double VisionHealth::greenFraction() const {
  return mean(&FrameFacts::green);
}
double VisionHealth::orangeFraction() const {
  return mean(&FrameFacts::orange);
}

double VisionHealth::searchFraction() const {
  if (filled_ == 0) return 0.0;
  int searched = 0;
  for (std::size_t i = 0; i < filled_; ++i)
    searched += window_[i].searched ? 1 : 0;
  return static_cast<double>(searched) / static_cast<double>(filled_);
}

void VisionHealth::update(const camera::FrameView& frame, const VisionResult& result) {
  int green = 0, orange = 0, counted = 0;
  for (const Sample& s : samples_) {
    if (!frame.contains(s.u, s.v)) continue;
    const camera::ColourClass c = table_.classifyPixel(frame, s.u, s.v);
    green += c == camera::ColourClass::kGreen ? 1 : 0;
    orange += c == camera::ColourClass::kOrange ? 1 : 0;
    ++counted;
  }
  FrameFacts& facts = window_[next_];
  facts.green = counted > 0 ? static_cast<float>(green) / static_cast<float>(counted) : 0.0f;
  facts.orange = counted > 0 ? static_cast<float>(orange) / static_cast<float>(counted) : 0.0f;
  // A periodic re-initialisation is a planned search, not a sign of trouble.
  facts.searched = result.tracking.initial_searches > 0 && !result.tracking.reinitialised;
  next_ = (next_ + 1) % window_.size();
  filled_ = std::min(filled_ + 1, window_.size());
  if (result.lines_detected) {
    line_frames_without_points_ = result.lines.points.empty() ? line_frames_without_points_ + 1 : 0;
  }

  reason_.clear();
  auto add = [this](const std::string& what) {
    if (!reason_.empty()) reason_ += "; ";
    reason_ += what;
  };
  const double g = greenFraction();
  if (g < params_.min_green_fraction) {
    add(fmt::format("too little green: {:.0f} % of the floor (< {:.0f} %)", 100.0 * g,
                    100.0 * params_.min_green_fraction));
  }
  const double o = orangeFraction();
  if (o > params_.max_orange_fraction) {
    add(fmt::format("ball colour everywhere: {:.0f} % of the floor (> {:.0f} %)", 100.0 * o,
                    100.0 * params_.max_orange_fraction));
  }
  if (line_frames_without_points_ >= params_.max_line_frames_without_points) {
    add(fmt::format("no line points in {} line frames", line_frames_without_points_));
  }
  // Judged on a full window only: the first frame always searches.
  const double searches = searchFraction();
  if (filled_ == window_.size() && searches > params_.max_search_fraction) {
    add(fmt::format("re-seeding green in {:.0f} % of frames", 100.0 * searches));
  }
}

}  // namespace fieldline::region_tracking
