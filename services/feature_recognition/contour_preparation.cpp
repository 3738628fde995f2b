#include "services/feature_recognition/contour_preparation.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace fieldline::feature_recognition {

std::string InputCheck::describe() const {
  std::string text;
  auto add = [&](int count, const char* what) {
    if (count == 0) return;
    if (!text.empty()) text += ", ";
    text += std::to_string(count) + " " + what;
  };
  if (too_many_points) text = "too many points, frame refused";
  add(out_of_range, "sequences out of range");
  add(overlapping, "overlapping sequences");
  add(non_finite, "sequences with non-finite points");
  return text;
}

void smoothSequence(const Vec2* p, int n, Vec2* out) {
  if (n <= 0) return;
  out[0] = p[0];
  for (int i = 1; i + 1 < n; ++i)
    out[i] = 0.25 * p[i - 1] + 0.5 * p[i] + 0.25 * p[i + 1];
  out[n - 1] = p[n - 1];
}

void turningAngles(const Vec2* p, int n, int w, std::vector<double>& out) {
  out.assign(static_cast<std::size_t>(std::max(n, 0)), 0.0);
  for (int i = 2; i + 2 < n; ++i) {
    // Near the ends the span shrinks (down to 2) so that corners there are still found.
    const int span = std::min({w, i, n - 1 - i});
    const Vec2 a = p[i] - p[i - span];
    const Vec2 b = p[i + span] - p[i];
    out[i] = std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
  }
}

void turningAnglesAbove(const Vec2* p, int n, int w, double threshold, std::vector<double>& out) {
  out.assign(static_cast<std::size_t>(std::max(n, 0)), 0.0);
  // |angle| <= threshold <=> the dot product is positive and |cross| <= tan(threshold) * dot
  // (threshold below pi / 2); only the angles above it are computed.
  const double tan_threshold = std::tan(std::clamp(threshold, 0.0, 1.5));
  for (int i = 2; i + 2 < n; ++i) {
    const int span = std::min({w, i, n - 1 - i});
    const Vec2 a = p[i] - p[i - span];
    const Vec2 b = p[i + span] - p[i];
    const double cross = a.x() * b.y() - a.y() * b.x(), dot = a.dot(b);
    if (threshold < 1.5 && dot > 0.0 && std::abs(cross) <= tan_threshold * dot) continue;
    out[i] = std::atan2(cross, dot);
  }
}

void curvatureMaxima(const std::vector<double>& turn, double threshold, int min_separation,
                     std::vector<int>& out) {
  out.clear();
  const int n = static_cast<int>(turn.size());
  int last_close = -min_separation - 1;
  int i = 0;
  while (i < n) {
    if (std::abs(turn[i]) <= threshold || i - last_close < min_separation) {
      ++i;
      continue;
    }
    int best = i;
    while (i < n && std::abs(turn[i]) > threshold) {
      if (std::abs(turn[i]) > std::abs(turn[best])) best = i;
      ++i;
    }
    out.push_back(best);
    last_close = i - 1;
  }
}

namespace {

bool finitePoint(const perception::LinePoint& p) {
  return std::isfinite(p.x) && std::isfinite(p.y);
}

// Smooths one run without jumps and splits it at its curvature maxima into out.pieces.
void splitRun(const Vec2* raw, int n, int w, const RecognitionParams& params, Contours& out,
              std::vector<double>& turn, std::vector<int>& splits) {
  if (n < params.min_piece_points) return;
  const int base = static_cast<int>(out.points.size());
  out.points.resize(base + n);
  Vec2* smoothed = out.points.data() + base;
  smoothSequence(raw, n, smoothed);
  turningAnglesAbove(smoothed, n, w, params.split_turn_angle, turn);
  curvatureMaxima(turn, params.split_turn_angle, params.split_min_separation, splits);
  int piece_start = 0;
  auto emit = [&](int b, int e) {
    if (e - b >= params.min_piece_points) out.pieces.push_back({base + b, base + e});
  };
  for (int s : splits) {
    // The corner point itself is rounded by the smoothing: it belongs to neither side.
    emit(piece_start, s);
    piece_start = s + 1;
  }
  emit(piece_start, n);
}

}  // namespace

InputCheck prepareContours(const perception::LinePoints& in, const RecognitionParams& params,
                           Contours& out) {
  out.clear();
  InputCheck check;
  const int num_points = static_cast<int>(std::min<std::size_t>(in.points.size(), 1u << 30));
  if (static_cast<int>(in.points.size()) > params.max_points ||
      static_cast<int>(in.sequences.size()) > params.max_points) {
    check.too_many_points = true;
    return check;
  }

  // Sequences in order of their start, so that overlaps are found in one sweep.
  thread_local std::vector<int> order;
  order.resize(in.sequences.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return in.sequences[a].first != in.sequences[b].first
               ? in.sequences[a].first < in.sequences[b].first
               : a < b;
  });

  thread_local std::vector<Vec2> raw;
  thread_local std::vector<double> turn;
  thread_local std::vector<int> splits;
  int covered_until = 0;
  // Sequences are processed in their original order (the tracker's contour order).
  thread_local std::vector<char> usable;
  usable.assign(in.sequences.size(), 0);
  for (int k : order) {
    const auto [start, end] = in.sequences[k];
    if (start < 0 || end > num_points || end < start) {
      ++check.out_of_range;
      continue;
    }
    if (start < covered_until) {
      ++check.overlapping;
      continue;
    }
    covered_until = std::max(covered_until, end);
    if (!std::all_of(in.points.begin() + start, in.points.begin() + end, finitePoint)) {
      ++check.non_finite;
      continue;
    }
    if (end - start < params.min_sequence_points) {
      ++check.too_short;
      continue;
    }
    usable[k] = 1;
  }

  const int w = std::max(params.curvature_span, 1);
  for (std::size_t k = 0; k < in.sequences.size(); ++k) {
    if (!usable[k]) continue;
    ++check.sequences_used;
    const auto [start, end] = in.sequences[k];
    const int n = end - start;
    raw.resize(n);
    for (int i = 0; i < n; ++i)
      raw[i] = Vec2(in.points[start + i].x, in.points[start + i].y);
    // Jumps (an occlusion, a gap the tracker bridged) cut the sequence into runs before the
    // smoothing, which would otherwise pull the two sides of a jump together.
    int run_start = 0;
    for (int i = 1; i <= n; ++i) {
      if (i < n && (raw[i] - raw[i - 1]).squaredNorm() <= params.split_gap * params.split_gap) {
        continue;
      }
      splitRun(raw.data() + run_start, i - run_start, w, params, out, turn, splits);
      run_start = i;
    }
  }
  return check;
}

}  // namespace fieldline::feature_recognition
