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
    const Sample& gone = samples_.front();
    if (gone.round_trip_us <= min_round_trip_us_) min_round_trip_known_ = false;
    forward_.erase({gone.sent, gone.forward_us});
    backward_.erase({gone.when, -gone.backward_us});
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
    rebuildEnvelopes();
    min_round_trip_known_ = false;
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
  forward_.insert({sample.sent, sample.forward_us});
  backward_.insert({sample.when, -sample.backward_us});
  if (min_round_trip_known_) {
    min_round_trip_us_ = std::min(min_round_trip_us_, sample.round_trip_us);
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
  forward_.clear();
  backward_.clear();
  min_round_trip_known_ = false;
  held_.clear();
  fitted_ = false;
  after_step_ = true;
}

namespace {

struct Line {
  double intercept = 0.0;  // at t = 0
  double slope = 0.0;
};

// One step of the monotone chain: `p` (not before the hull's last point) joins the lower hull.
// Differences of times are exact in double (|t - t'| < 2^53 µs), so these are the decisions of
// the chain over times taken relative to any reference.
template <typename P>
void pushHull(std::vector<P>& hull, const P& p) {
  while (hull.size() >= 2) {
    const P& o = hull[hull.size() - 2];
    const P& a = hull.back();
    const double cross =
        static_cast<double>(a.t - o.t) * (p.y - o.y) - (a.y - o.y) * static_cast<double>(p.t - o.t);
    if (cross > 0.0) break;
    hull.pop_back();
  }
  if (!hull.empty() && hull.back().t == p.t) {
    if (p.y < hull.back().y) hull.back() = p;
    return;
  }
  hull.push_back(p);
}

}  // namespace

double ClockOffsetEstimator::Envelope::meanTime(Utime reference) const {
  const auto n = static_cast<std::int64_t>(points.size());
  return static_cast<double>(sum_t - n * (reference - base)) / static_cast<double>(n);
}

void ClockOffsetEstimator::Envelope::insert(Point p) {
  if (points.empty()) base = p.t;
  sum_t += p.t - base;
  if (points.empty() || !(p < points.back())) {
    points.push_back(p);
    pushHull(hull, p);
    return;
  }
  // Out of time order (rare): sorted in, the hull made afresh.
  points.insert(std::upper_bound(points.begin(), points.end(), p), p);
  rebuild();
}

void ClockOffsetEstimator::Envelope::erase(Point p) {
  if (points.empty()) return;
  if (!(points.front() == p)) {
    const auto it = std::find(points.begin(), points.end(), p);
    if (it != points.end()) {
      points.erase(it);
      sum_t -= p.t - base;
    }
    rebuild();
    return;
  }
  points.pop_front();
  sum_t -= p.t - base;
  // The hull's vertices from the first one still present on stay vertices (removing points only
  // uncovers points below the first edge): the chain is made again up to that vertex only.
  std::size_t keep = 0;
  while (keep < hull.size() && hull[keep] < points.front())
    ++keep;
  if (points.empty() || keep == hull.size()) {
    rebuild();
    return;
  }
  scratch.clear();
  for (std::size_t i = 0; i < points.size() && !(hull[keep] < points[i]); ++i)
    pushHull(scratch, points[i]);
  scratch.insert(scratch.end(), hull.begin() + static_cast<std::ptrdiff_t>(keep) + 1, hull.end());
  hull.swap(scratch);
}

void ClockOffsetEstimator::Envelope::rebuild() {
  hull.clear();
  for (const Point& p : points)
    pushHull(hull, p);
}

void ClockOffsetEstimator::Envelope::clear() {
  points.clear();
  hull.clear();
  sum_t = 0;
}

void ClockOffsetEstimator::rebuildEnvelopes() {
  forward_.clear();
  backward_.clear();
  for (const Sample& s : samples_) {
    forward_.insert({s.sent, s.forward_us});
    backward_.insert({s.when, -s.backward_us});
  }
}

namespace {

// The line below every point that is highest at the points' mean time: the edge of their lower
// convex hull above that time (the envelope of the smallest delays), times relative to
// `reference`.
template <typename Envelope>
Line lowerEnvelope(const Envelope& env, Utime reference, bool fit_slope, double max_slope) {
  const double t_mean = env.meanTime(reference);
  if (!fit_slope || env.points.size() < 2) {
    double lowest = env.points.front().y;
    for (const auto& p : env.points)
      lowest = std::min(lowest, p.y);
    return {lowest, 0.0};
  }
  const auto& hull = env.hull;
  std::size_t i = 0;
  while (i + 2 < hull.size() && static_cast<double>(hull[i + 1].t - reference) < t_mean)
    ++i;
  if (hull.size() < 2) return {hull.front().y, 0.0};
  const auto& a = hull[i];
  const auto& b = hull[i + 1];
  const double slope =
      std::clamp((b.y - a.y) / static_cast<double>(b.t - a.t), -max_slope, max_slope);
  // Through the lower of the edge's ends after clamping, so the line stays below both.
  const double intercept = std::min(a.y - slope * static_cast<double>(a.t - reference),
                                    b.y - slope * static_cast<double>(b.t - reference));
  return {intercept, slope};
}

}  // namespace

void ClockOffsetEstimator::refit() {
  fitted_ = false;
  if (samples_.empty()) return;
  // Each round trip carries one delay each way: our packet's (t2 - t1 = offset + delay there)
  // and theirs (t3 - t4 = offset - delay back). The smallest delays each way bound the offset
  // from above and below; their envelopes over the window, found separately for each direction
  // (so the best of each need not come in the same round trip), give offset and drift. The way
  // back's upper envelope is the lower envelope of its negation.
  reference_ = samples_.back().when;
  if (!min_round_trip_known_) {
    min_round_trip_us_ = std::numeric_limits<Utime>::max();
    for (const Sample& s : samples_)
      min_round_trip_us_ = std::min(min_round_trip_us_, s.round_trip_us);
    min_round_trip_known_ = true;
  }
  const Utime span = samples_.back().when - samples_.front().when;
  const bool fit_slope = samples_.size() >= 3 && span >= options_.min_fit_span_us;
  const double max_slope = options_.max_drift_ppm * 1e-6;
  const Line up = lowerEnvelope(forward_, reference_, fit_slope, max_slope);
  const Line down = lowerEnvelope(backward_, reference_, fit_slope, max_slope);
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
