#include "teamcomm/clock_offset.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace fieldline::teamcomm {

ClockOffsetEstimator::ClockOffsetEstimator(OffsetOptions options) : options_(options) {}

bool ClockOffsetEstimator::add(const RoundTrip& rt) {
  const Utime round_trip =
      (rt.t4_our_receive - rt.t1_our_send) - (rt.t3_their_send - rt.t2_their_receive);
  // The teammate's hold time and our round trip are both measured on steady-ish clocks; a
  // negative round trip beyond stamping noise means the echo is not ours to trust.
  if (round_trip < -static_cast<Utime>(2 * options_.min_sigma_us) ||
      round_trip > options_.max_round_trip_us || rt.t3_their_send < rt.t2_their_receive ||
      rt.t4_our_receive < rt.t1_our_send) {
    return false;
  }
  const double offset = 0.5 * (static_cast<double>(rt.t2_their_receive - rt.t1_our_send) +
                               static_cast<double>(rt.t3_their_send - rt.t4_our_receive));
  samples_.push_back({rt.t4_our_receive, offset, std::max<Utime>(round_trip, 0)});
  // Samples arrive in our time order; anything that claims otherwise is sorted in.
  for (std::size_t i = samples_.size() - 1; i > 0 && samples_[i].when < samples_[i - 1].when; --i) {
    std::swap(samples_[i], samples_[i - 1]);
  }
  const Utime newest = samples_.back().when;
  while (!samples_.empty() && samples_.front().when < newest - options_.window_us) {
    samples_.pop_front();
  }
  refit();
  return true;
}

void ClockOffsetEstimator::refit() {
  fitted_ = false;
  if (samples_.empty()) return;
  Utime min_rt = std::numeric_limits<Utime>::max();
  for (const Sample& s : samples_)
    min_rt = std::min(min_rt, s.round_trip_us);
  min_round_trip_us_ = min_rt;
  // The minimum round trip wins: a sample's offset error is bounded by how much longer its round
  // trip was than the best in the window, so its weight falls with that excess. A weighted line
  // through all of them gives the drift.
  double sw = 0, st = 0, so = 0;
  reference_ = samples_.back().when;
  std::vector<std::pair<double, double>> points;  // (t - reference, offset)
  std::vector<double> weights;
  for (const Sample& s : samples_) {
    const double sigma =
        options_.min_sigma_us + 0.5 * static_cast<double>(s.round_trip_us - min_rt);
    const double w = 1.0 / (sigma * sigma);
    points.emplace_back(static_cast<double>(s.when - reference_), s.offset_us);
    weights.push_back(w);
    sw += w;
    st += w * points.back().first;
    so += w * points.back().second;
  }
  const double t_mean = st / sw;
  const double o_mean = so / sw;
  double stt = 0, sto = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double dt = points[i].first - t_mean;
    stt += weights[i] * dt * dt;
    sto += weights[i] * dt * (points[i].second - o_mean);
  }
  const Utime span = samples_.back().when - samples_.front().when;
  slope_ = 0.0;
  if (points.size() >= 3 && span >= options_.min_fit_span_us && stt > 0.0) {
    const double max_slope = options_.max_drift_ppm * 1e-6;
    slope_ = std::clamp(sto / stt, -max_slope, max_slope);
  }
  intercept_us_ = o_mean - slope_ * t_mean;
  fitted_ = true;
}

std::optional<OffsetEstimate> ClockOffsetEstimator::estimate(Utime now_ours) const {
  if (!fitted_) return std::nullopt;
  OffsetEstimate e;
  e.offset_us = intercept_us_ + slope_ * static_cast<double>(now_ours - reference_);
  e.drift_ppm = slope_ * 1e6;
  e.min_round_trip_us = min_round_trip_us_;
  e.uncertainty_us = 0.5 * static_cast<double>(min_round_trip_us_);
  return e;
}

std::optional<Utime> ClockOffsetEstimator::toOurs(Utime their_utime) const {
  if (!fitted_) return std::nullopt;
  // their = ours + intercept + slope * (ours - reference), solved for ours.
  const double ours =
      (static_cast<double>(their_utime - reference_) - intercept_us_) / (1.0 + slope_);
  return reference_ + static_cast<Utime>(std::llround(ours));
}

std::optional<Utime> ClockOffsetEstimator::toTheirs(Utime our_utime) const {
  const auto e = estimate(our_utime);
  if (!e) return std::nullopt;
  return our_utime + static_cast<Utime>(std::llround(e->offset_us));
}

}  // namespace fieldline::teamcomm
