#include "teamcomm/clock_offset.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace fieldline::teamcomm {

const char* toString(RoundTripUse u) {
  switch (u) {
    case RoundTripUse::kAdded:
      return "added";
    case RoundTripUse::kRefused:
      return "refused";
    case RoundTripUse::kHeld:
      return "held";
    case RoundTripUse::kStep:
      return "step";
  }
  return "unknown";
}

ClockOffsetEstimator::ClockOffsetEstimator(OffsetOptions options) : options_(options) {}

bool ClockOffsetEstimator::plausible(const RoundTrip& rt) const {
  const Utime round_trip =
      (rt.t4_our_receive - rt.t1_our_send) - (rt.t3_their_send - rt.t2_their_receive);
  // The teammate's hold time and our round trip are both measured on steady-ish clocks; a
  // negative round trip beyond stamping noise means the echo is not ours to trust.
  return round_trip >= -static_cast<Utime>(2 * options_.min_sigma_us) &&
         round_trip <= options_.max_round_trip_us && rt.t3_their_send >= rt.t2_their_receive &&
         rt.t4_our_receive >= rt.t1_our_send;
}

bool ClockOffsetEstimator::agreesWithFit(const Sample& s) const {
  const double dt = static_cast<double>(s.when - reference_);
  const double line = intercept_us_ + slope_ * dt;
  // The fit is off by at most half its smallest round trip; beyond its newest round trip the
  // drift may be off by up to twice the plausible maximum.
  const double tolerance = 0.5 * static_cast<double>(min_round_trip_us_) + options_.step_slack_us +
                           2.0 * options_.min_sigma_us +
                           2.0 * options_.max_drift_ppm * 1e-6 * std::abs(dt);
  return s.backward_us - tolerance <= line && line <= s.forward_us + tolerance;
}

RoundTripUse ClockOffsetEstimator::add(const RoundTrip& rt) {
  if (!plausible(rt)) return RoundTripUse::kRefused;
  const Utime round_trip =
      (rt.t4_our_receive - rt.t1_our_send) - (rt.t3_their_send - rt.t2_their_receive);
  const Sample sample{
      rt.t4_our_receive, rt.t1_our_send, static_cast<double>(rt.t2_their_receive - rt.t1_our_send),
      static_cast<double>(rt.t3_their_send - rt.t4_our_receive), std::max<Utime>(round_trip, 0)};
  // The window as of this round trip: a teammate silent for longer starts afresh.
  const Utime newest = samples_.empty() ? sample.when : std::max(sample.when, samples_.back().when);
  const std::size_t before = samples_.size();
  while (!samples_.empty() && samples_.front().when < newest - options_.window_us) {
    samples_.pop_front();
  }
  if (samples_.size() != before) refit();

  if (fitted_ && !agreesWithFit(sample)) {
    held_.push_back(sample);
    // Held round trips must agree with each other: the oldest go until the rest share an offset.
    const auto common = [this] {
      double lowest_forward = std::numeric_limits<double>::max();
      double highest_backward = std::numeric_limits<double>::lowest();
      for (const Sample& h : held_) {
        lowest_forward = std::min(lowest_forward, h.forward_us);
        highest_backward = std::max(highest_backward, h.backward_us);
      }
      const double span = static_cast<double>(held_.back().when - held_.front().when);
      const double tolerance = options_.step_slack_us + 2.0 * options_.min_sigma_us +
                               2.0 * options_.max_drift_ppm * 1e-6 * span;
      return highest_backward - tolerance <= lowest_forward + tolerance;
    };
    while (held_.size() > 1 &&
           (!common() || held_.front().when < sample.when - options_.window_us)) {
      held_.pop_front();
    }
    if (static_cast<int>(held_.size()) < options_.step_confirmations) return RoundTripUse::kHeld;
    const double old_line = intercept_us_ + slope_ * static_cast<double>(sample.when - reference_);
    samples_.assign(held_.begin(), held_.end());
    held_.clear();
    refit();
    ++steps_;
    last_step_ = ClockStep{sample.when, intercept_us_ - old_line};
    after_step_ = true;
    return RoundTripUse::kStep;
  }
  held_.clear();
  samples_.push_back(sample);
  // Samples arrive in our time order; anything that claims otherwise is sorted in.
  for (std::size_t i = samples_.size() - 1; i > 0 && samples_[i].when < samples_[i - 1].when; --i) {
    std::swap(samples_[i], samples_[i - 1]);
  }
  refit();
  return RoundTripUse::kAdded;
}

bool ClockOffsetEstimator::converging() const {
  if (!after_step_) return false;
  return samples_.empty() ||
         samples_.back().when - samples_.front().when < options_.min_fit_span_us;
}

void ClockOffsetEstimator::reset() {
  samples_.clear();
  held_.clear();
  fitted_ = false;
  after_step_ = true;
}

namespace {

struct Line {
  double intercept = 0.0;  // at t = 0
  double slope = 0.0;
};

// The line below every point that is highest at the points' mean time: the edge of their lower
// convex hull above that time (the envelope of the smallest delays). Points sorted by t.
Line lowerEnvelope(const std::vector<std::pair<double, double>>& points, bool fit_slope,
                   double max_slope) {
  double t_mean = 0.0;
  for (const auto& p : points)
    t_mean += p.first;
  t_mean /= static_cast<double>(points.size());
  if (!fit_slope || points.size() < 2) {
    double lowest = points.front().second;
    for (const auto& p : points)
      lowest = std::min(lowest, p.second);
    return {lowest, 0.0};
  }
  std::vector<std::pair<double, double>> hull;
  for (const auto& p : points) {
    while (hull.size() >= 2) {
      const auto& o = hull[hull.size() - 2];
      const auto& a = hull.back();
      const double cross =
          (a.first - o.first) * (p.second - o.second) - (a.second - o.second) * (p.first - o.first);
      if (cross > 0.0) break;
      hull.pop_back();
    }
    if (!hull.empty() && hull.back().first == p.first) {
      if (p.second < hull.back().second) hull.back() = p;
      continue;
    }
    hull.push_back(p);
  }
  std::size_t i = 0;
  while (i + 2 < hull.size() && hull[i + 1].first < t_mean)
    ++i;
  if (hull.size() < 2) return {hull.front().second, 0.0};
  const auto& a = hull[i];
  const auto& b = hull[i + 1];
  const double slope =
      std::clamp((b.second - a.second) / (b.first - a.first), -max_slope, max_slope);
  // Through the lower of the edge's ends after clamping, so the line stays below both.
  const double intercept = std::min(a.second - slope * a.first, b.second - slope * b.first);
  return {intercept, slope};
}

// Sorts points that are nearly in order already, as the window's are (each new round trip comes
// last, and its t1 is rarely before the previous one's): insertion sort, linear on them where
// std::sort is n log n. The same order std::sort gives (the order of the pairs is total).
void sortNearlySorted(std::vector<std::pair<double, double>>& points) {
  for (std::size_t i = 1; i < points.size(); ++i) {
    if (!(points[i] < points[i - 1])) continue;
    const auto p = points[i];
    std::size_t j = i;
    for (; j > 0 && p < points[j - 1]; --j)
      points[j] = points[j - 1];
    points[j] = p;
  }
}

}  // namespace

void ClockOffsetEstimator::refit() {
  fitted_ = false;
  if (samples_.empty()) return;
  // Each round trip carries one delay each way: our packet's (t2 - t1 = offset + delay there)
  // and theirs (t3 - t4 = offset - delay back). The smallest delays each way bound the offset
  // from above and below; their envelopes over the window, found separately for each direction
  // (so the best of each need not come in the same round trip), give offset and drift.
  reference_ = samples_.back().when;
  std::vector<std::pair<double, double>> forward, backward;
  forward.reserve(samples_.size());
  backward.reserve(samples_.size());
  Utime min_rt = std::numeric_limits<Utime>::max();
  for (const Sample& s : samples_) {
    forward.emplace_back(static_cast<double>(s.sent - reference_), s.forward_us);
    // The upper envelope of the way back, as the lower envelope of its negation.
    backward.emplace_back(static_cast<double>(s.when - reference_), -s.backward_us);
    min_rt = std::min(min_rt, s.round_trip_us);
  }
  sortNearlySorted(forward);
  sortNearlySorted(backward);
  min_round_trip_us_ = min_rt;
  const Utime span = samples_.back().when - samples_.front().when;
  const bool fit_slope = samples_.size() >= 3 && span >= options_.min_fit_span_us;
  const double max_slope = options_.max_drift_ppm * 1e-6;
  const Line up = lowerEnvelope(forward, fit_slope, max_slope);
  const Line down = lowerEnvelope(backward, fit_slope, max_slope);
  // offset + minimum delay there, and offset - minimum delay back: equal minimum delays cancel.
  intercept_us_ = 0.5 * (up.intercept - down.intercept);
  slope_ = 0.5 * (up.slope - down.slope);
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
