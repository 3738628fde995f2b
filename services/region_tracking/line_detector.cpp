#include "services/region_tracking/line_detector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>

#include "services/region_tracking/detector_pixels.hpp"
#include "services/region_tracking/frame_classifier.hpp"

namespace fieldline::region_tracking {

using detail::nearestPixel;

// Bins of equal length on the diamond |u| + |v| = 1, counter-clockwise from +u: no atan2, and
// no bin is wider than 2 * 360 / kDirections degrees.
[[gnu::always_inline]] inline int LineDetector::directionOf(float normalU, float normalV) {
  const float sum = std::abs(normalU) + std::abs(normalV);
  float p;
  if (normalV >= 0.0f) {
    p = normalU >= 0.0f ? normalV / sum : 1.0f - normalU / sum;
  } else {
    p = normalU < 0.0f ? 2.0f - normalV / sum : 3.0f + normalU / sum;
  }
  return std::min(static_cast<int>(p * (kDirections / 4)), kDirections - 1);
}

// long: the detector's per-pixel hot loop along one normal, kept whole so that the walk's
// state stays in registers.
template <camera::PixelFormat kFormat>
bool LineDetector::scan(const camera::FrameView& frame, float originU, float originV, float normalU,
                        float normalV, float& lineU, float& lineV) {
  const int ou = nearestPixel(originU);
  const int ov = nearestPixel(originV);
  // Inside the frame: one unsigned comparison per coordinate (negative ones wrap to large).
  const unsigned width = static_cast<unsigned>(frame.width);
  const unsigned height = static_cast<unsigned>(frame.height);
  const auto inFrame = [&](const int u, const int v) {
    return (static_cast<unsigned>(u) < width) & (static_cast<unsigned>(v) < height);
  };
  if (!inFrame(ou, ov)) return false;
  if (!usable(ou, ov)) return false;
  const int maxRun = maxRunAt(ou, ov);
  const int direction = directionOf(normalU, normalV);
  const std::size_t walkAt = static_cast<std::size_t>(direction) * walk_capacity_;
  const Step* walk = &walks_[walkAt];
  const std::uint8_t* countUpTo = &walk_count_up_to_[walkAt];
  // Boundaries along the edge of the view face unusable pixels: nothing to find there.
  const Step probe = probes_[direction];
  if (!inFrame(ou + probe.du, ov + probe.dv) || !usable(ou + probe.du, ov + probe.dv)) {
    return false;
  }
  // Up to `stop` steps: the cell, the longest run here, both transitions, the confirmation.
  int count = countUpTo[stop_step_base_ + maxRun];
  // The walk is a straight line: inside the frame if both ends are; else cut it where it
  // leaves (running into the cut is a miss, as running past `stop`).
  const auto inside = [&](const Step s) { return inFrame(ou + s.du, ov + s.dv); };
  if (!inside(walk[0])) return false;
  if (!inside(walk[count - 1])) {
    int within = 1;
    while (within < count && inside(walk[within]))
      ++within;
    count = within;
  }

  // Walk the normal pixel by pixel looking for: field ... [transition] line-run [transition]
  // field, keeping each pixel's brightness for the sub-pixel edges.
  constexpr int kBytesPerPixel = kFormat == camera::PixelFormat::kYuyv ? 2 : 3;
  // The origin's row; a step's pixel is found from its offsets (a multiplication costs less
  // than a table of byte offsets per walk step, which would crowd the cache).
  const std::ptrdiff_t stride = frame.stride;
  const std::uint8_t* originRow = frame.data + static_cast<std::ptrdiff_t>(ov) * stride;
  const camera::ColourClass* lookup = lookup_->data();
  // On the stack, so that storing a brightness cannot alias the colour table's pointer (which
  // would be reloaded for every pixel). Walks have at most 255 steps (8-bit offsets).
  std::array<std::uint8_t, kMaxWalk> luma;
  // Class of step `i` of the walk; keeps its brightness in luma[i].
  const auto classAt = [&](const int i) {
    camera::Yuv yuv;
    const Step step = walk[i];
    const std::uint8_t* row = originRow + step.dv * stride;
    const int u = ou + step.du;
    if constexpr (kFormat == camera::PixelFormat::kYuyv) {
      // The pair's Y0 U Y1 V in one read from the pair's even pixel: Y at byte 0 or 2 by the
      // pixel's parity, U and V at 1 and 3.
      const unsigned odd = static_cast<unsigned>(u) & 1u;
      std::uint32_t word;
      std::memcpy(&word, row + (static_cast<std::ptrdiff_t>(u - static_cast<int>(odd)) << 1),
                  sizeof word);
      yuv = {static_cast<std::uint8_t>(word >> (odd << 4)), static_cast<std::uint8_t>(word >> 8),
             static_cast<std::uint8_t>(word >> 24)};
    } else {
      const std::uint8_t* pixel = row + static_cast<std::ptrdiff_t>(u) * kBytesPerPixel;
      yuv = camera::yuvFromBgr({pixel[0], pixel[1], pixel[2]});
    }
    luma[i] = yuv.y;
    return lookup[ClassLookup::yPart(yuv.y) | ClassLookup::uvPart(yuv.u, yuv.v)];
  };
  const camera::ColourClass field_colour = params_.field_colour;
  const camera::ColourClass line_colour = params_.line_colour;
  const int maxTransition = params_.max_transition_pixels;
  // A ridge (blurred line without line-coloured pixels) may span the longest run and both
  // transitions: pixels of no class after the field may go on that long.
  const bool ridges = params_.ridge_contrast > 0.0;
  const int maxRidge = ridges ? maxRun + 2 * maxTransition : maxTransition;
  bool ridgeEligible = true;  // every pixel since the last field pixel is unclassified
  // The first ridge met: its field pixel before, peak and field pixel after. A run of the line
  // colour further along the walk wins over it (a ridge right before a line is mostly that
  // line's blurred edge with a pixel of it classified as field).
  int ridgeField = -1, ridgeAt = -1, ridgeAfter = -1;
  bool sawField = false;
  int lastField = -1, runStart = -1, runEnd = -1, transition = 0;
  int fieldAfter = -1;  // the first field pixel after the run
  int index = 0;
  bool found = false;
  bool stopped = false;  // the walk ended before its last pixel
  // Before the line: field, then at most maxTransition pixels of other classes (maxRidge of no
  // class), then the line's first pixel.
  for (; index < count; ++index) {
    const camera::ColourClass c = classAt(index);
    if (c == field_colour) {
      if (transition > 0 && ridgeEligible && ridges && ridgeAt < 0) {
        const int peak = ridgePeak(luma.data(), lastField, index);
        if (peak >= 0) {  // field - a ridge of brightness - field: a blurred line
          ridgeField = lastField;
          ridgeAt = peak;
          ridgeAfter = index;
        }
      }
      sawField = true;
      lastField = index;
      transition = 0;
      ridgeEligible = true;
    } else if (c == line_colour) {
      if (!sawField || transition > maxTransition) {
        stopped = true;
        break;
      }
      runStart = runEnd = index;
      break;
    } else if (sawField) {
      ridgeEligible = ridgeEligible && c == camera::ColourClass::kUnknown;
      ++transition;
      if (transition > (ridgeEligible ? maxRidge : maxTransition)) {
        stopped = true;
        break;
      }
    }
  }
  if (!stopped && runStart >= 0) {
    // On the line, or back on it after a hole of noise, until field pixels confirm its end.
    const int maxGap = params_.max_gap_pixels;
    const int confirm = params_.field_confirm_pixels;
    const bool endAtSelf = params_.end_at_self;
    int fieldCount = 0;  // field pixels since fieldAfter
    for (++index; index < count; ++index) {
      const camera::ColourClass c = classAt(index);
      if (c == line_colour) {
        if (fieldAfter >= 0) {  // field came between: the line ended there, another one begins
          found = true;
          break;
        }
        if (index - runEnd - 1 > maxGap) break;
        runEnd = index;
        fieldCount = 0;
        if (runEnd - runStart + 1 > maxRun) break;
      } else {
        if (c == field_colour) {
          if (fieldAfter < 0) fieldAfter = index;
          if (++fieldCount >= confirm) {  // back on the field: found
            found = true;
            break;
          }
        } else if (endAtSelf && fieldAfter < 0 &&
                   floor_.inSelf(ou + walk[index].du, ov + walk[index].dv)) {
          // The robot's own reflection right after the line: its dark edge ends the line.
          fieldAfter = index;
          found = true;
          break;
        }
        if (index - runEnd > maxTransition + confirm) break;
      }
    }
  }
  // A field pixel that the walk's end left unconfirmed still ends the line.
  if (!found && runStart >= 0 && fieldAfter >= 0 && index == count) found = true;
  if (!found && ridgeAt >= 0) {  // no line-coloured run: the ridge is the line
    lastField = ridgeField;
    runStart = runEnd = ridgeAt;
    fieldAfter = ridgeAfter;
    found = true;
  }
  const int read = std::min(index + 1, count);
  pixels_read_ += read;
  if (!found) return false;
  // Positions along the exact (unit) normal, only now that there is something to place.
  const float inverseLength = 1.0f / std::sqrt(normalU * normalU + normalV * normalV);
  walk_ = walk;
  walk_fraction_u_ = originU - static_cast<float>(ou);
  walk_fraction_v_ = originV - static_cast<float>(ov);
  walk_normal_u_ = normalU * inverseLength;
  walk_normal_v_ = normalV * inverseLength;
  const std::uint8_t peak = *std::max_element(&luma[runStart], &luma[runEnd] + 1);
  const float middle = 0.5f * (risingEdge(luma.data(), lastField, runStart, peak) +
                               fallingEdge(luma.data(), runEnd, peak, fieldAfter));
  lineU = originU + walk_normal_u_ * middle;
  lineV = originV + walk_normal_v_ * middle;
  return true;
}

int LineDetector::ridgePeak(const std::uint8_t* luma, int fieldBefore, int fieldAfter) const {
  const int peak =
      static_cast<int>(std::max_element(&luma[fieldBefore + 1], &luma[fieldAfter]) - luma);
  const int field = std::max(luma[fieldBefore], luma[fieldAfter]);
  const bool bright = luma[peak] >= params_.ridge_contrast * field &&
                      luma[peak] >= field + params_.ridge_min_levels;
  return bright ? peak : -1;
}

// Where the brightness crosses halfway between the field before the line and the line's
// brightest sample, interpolated between the two samples around the crossing.
[[gnu::always_inline]] inline float LineDetector::risingEdge(const std::uint8_t* luma, int field,
                                                             int runStart,
                                                             std::uint8_t peak) const {
  const float threshold = 0.5f * (static_cast<float>(luma[field]) + peak);
  for (int i = field; i < runStart; ++i) {
    const float a = luma[i], b = luma[i + 1];
    if (a < threshold && b >= threshold) {
      const float ta = along(i), tb = along(i + 1);
      return ta + (tb - ta) * (threshold - a) / (b - a);
    }
  }
  return 0.5f * (along(runStart - 1) + along(runStart));
}

[[gnu::always_inline]] inline float LineDetector::fallingEdge(const std::uint8_t* luma, int runEnd,
                                                              std::uint8_t peak, int field) const {
  const float threshold = 0.5f * (static_cast<float>(luma[field]) + peak);
  for (int i = runEnd; i < field; ++i) {
    const float a = luma[i], b = luma[i + 1];
    if (a >= threshold && b < threshold) {
      const float ta = along(i), tb = along(i + 1);
      return ta + (tb - ta) * (a - threshold) / (a - b);
    }
  }
  return 0.5f * (along(runEnd) + along(runEnd + 1));
}

[[gnu::always_inline]] inline void LineDetector::tangentAt(const ContourWork& w, int centre,
                                                           float& tu, float& tv) const {
  const float* su = &smooth_u_[w.smooth_begin];
  const float* sv = &smooth_v_[w.smooth_begin];
  int ahead = centre + w.tangent_reach, behind = centre - w.tangent_reach;
  if (ahead >= w.smoothed) ahead %= w.smoothed;
  if (behind < 0) behind = (behind % w.smoothed + w.smoothed) % w.smoothed;
  tu = su[ahead] - su[behind];
  tv = sv[ahead] - sv[behind];
}

[[gnu::always_inline]] inline void LineDetector::scanAcross(const camera::FrameView& frame,
                                                            float originU, float originV, float tu,
                                                            float tv, Hit& hit) {
  if (tu * tu + tv * tv < 1e-6f) return;
  // The region lies to the right of the walking direction on screen: outward is left. The
  // walk needs only the normal's direction; scan() normalises it when it finds a line.
  const float normalU = tv;
  const float normalV = -tu;
  float lineU = 0, lineV = 0;
  ++scans_;
  const bool found = frame.format == camera::PixelFormat::kYuyv
                         ? scan<camera::PixelFormat::kYuyv>(frame, originU, originV, normalU,
                                                            normalV, lineU, lineV)
                         : scan<camera::PixelFormat::kBgr>(frame, originU, originV, normalU,
                                                           normalV, lineU, lineV);
  if (!found) return;
  hit = {true, {lineU, lineV, 0.0f, 0.0f}};
  floor_.prefetch(lineU, lineV);
}

[[gnu::always_inline]] inline void LineDetector::scanAt(const camera::FrameView& frame,
                                                        const ContourWork& w, float position,
                                                        Hit& hit) {
  const float* su = &smooth_u_[w.smooth_begin];
  const float* sv = &smooth_v_[w.smooth_begin];
  int centre = static_cast<int>(position);
  const float f = position - static_cast<float>(centre);
  if (centre >= w.smoothed) centre -= w.smoothed;
  const int after = centre + 1 == w.smoothed ? 0 : centre + 1;
  float tu, tv, tu1, tv1;
  tangentAt(w, centre, tu, tv);
  tangentAt(w, after, tu1, tv1);
  tu += f * (tu1 - tu);
  tv += f * (tv1 - tv);
  scanAcross(frame, su[centre] + f * (su[after] - su[centre]),
             sv[centre] + f * (sv[after] - sv[centre]), tu, tv, hit);
}

// Apart from the scans: the table is large, and looking each hit up right after its scan waited
// on memory for every point.
void LineDetector::toFloor(Hit* hits, std::size_t count) const {
  for (std::size_t i = 0; i < count; ++i) {
    Hit& hit = hits[i];
    if (hit.found)
      hit.found = floor_.floorPoint(hit.point.u, hit.point.v, hit.point.x, hit.point.y);
  }
}

void LineDetector::detect(const camera::FrameView& frame, const ContourSet& contours,
                          LinePoints& out) {
  if (frame.width != floor_.width() || frame.height != floor_.height()) {
    throw std::invalid_argument("line detector: frame size differs from the floor lookup's");
  }
  out.clear();
  pixels_read_ = 0;
  scans_ = 0;
  scanContours(frame, contours);
  merged_hits_.clear();
  refined_.clear();
  if (params_.sample_spacing_m <= 0.0 && params_.refine_range_m > 0.0) refineContours(frame);
  groupSequences(out);
}

void LineDetector::scanContours(const camera::FrameView& frame, const ContourSet& contours) {
  const ClassId field = classIdOf(params_.field_colour);
  const int spacing = params_.sample_spacing;
  const int k = params_.tangent_half_span;
  const bool byDistance = params_.sample_spacing_m > 0.0;
  work_.clear();
  smooth_u_.clear();
  smooth_v_.clear();
  hits_.clear();
  for (const Contour& contour : contours.contours) {
    if (contour.class_id != field || contour.size() < params_.min_contour_points) continue;
    const int n = contour.size();
    const ContourPoint* corners = &contours.points[contour.begin];
    // The contour is a staircase of cell sides; smoothing turns it into a curve with usable
    // tangents (the seed smooths before taking differences, section 3.3). Only the corners
    // that are sampled or give a sample's tangent are smoothed: every `stride`-th one.
    const int stride = !byDistance && n % std::gcd(spacing, k) == 0 ? std::gcd(spacing, k) : 1;
    ContourWork w;
    w.smoothed = n / stride;
    w.smooth_begin = static_cast<int>(smooth_u_.size());
    smooth_u_.resize(w.smooth_begin + w.smoothed);
    smooth_v_.resize(w.smooth_begin + w.smoothed);
    float* su = &smooth_u_[w.smooth_begin];
    float* sv = &smooth_v_[w.smooth_begin];
    smoothContour(corners, n, stride, su, sv);
    if (byDistance) sampleByDistance(su, sv, n, sample_positions_);
    // Indices among the smoothed corners: no division per sample but at the contour's ends.
    w.sample_step = spacing / stride;
    w.tangent_reach = k / stride;
    w.samples = byDistance ? static_cast<int>(sample_positions_.size()) : n / spacing;
    w.hits_begin = hits_.size();
    Hit* hits = hits_.appendMisses(w.samples);
    for (int s = 0; s < w.samples; ++s) {
      if (byDistance) {
        scanAt(frame, w, sample_positions_[s], hits[s]);
      } else {
        const int centre = s * w.sample_step;
        float tu, tv;
        tangentAt(w, centre, tu, tv);
        scanAcross(frame, su[centre], sv[centre], tu, tv, hits[s]);
      }
    }
    work_.push_back(w);
  }
  toFloor(hits_.data(), static_cast<std::size_t>(hits_.size()));
}

void LineDetector::refineContours(const camera::FrameView& frame) {
  const float perMetre =
      params_.refine_spacing_m > 0.0 ? static_cast<float>(1.0 / params_.refine_spacing_m) : 0.0f;
  for (ContourWork& w : work_) {
    if (w.samples < 3 || !markRefinedIntervals(w)) continue;
    refineContour(frame, w, perMetre);
  }
  for (const auto& [first, count] : refined_)
    toFloor(&merged_hits_[first], static_cast<std::size_t>(count));
}

bool LineDetector::markRefinedIntervals(const ContourWork& w) {
  const float maxRange2 = static_cast<float>(params_.refine_range_m * params_.refine_range_m);
  const float minRange2 =
      static_cast<float>(params_.refine_min_range_m * params_.refine_min_range_m);
  const float cosTurn = static_cast<float>(std::cos(params_.refine_turn));
  const int reach = params_.refine_reach;
  const int samples = w.samples;
  const Hit* hits = &hits_[w.hits_begin];
  refine_interval_.assign(samples, 0);
  bool any = false;
  for (int s = 0; s < samples; ++s) {
    const Hit& hit = hits[s];
    if (!hit.found) continue;
    const float range2 = hit.point.x * hit.point.x + hit.point.y * hit.point.y;
    if (range2 > maxRange2 || range2 < minRange2) continue;
    const Hit& before = hits[s == 0 ? samples - 1 : s - 1];
    const Hit& after = hits[s + 1 == samples ? 0 : s + 1];
    if (!before.found && !after.found && !params_.refine_isolated) continue;
    bool event = !before.found || !after.found;
    if (!event) {
      const float ax = hit.point.x - before.point.x, ay = hit.point.y - before.point.y;
      const float bx = after.point.x - hit.point.x, by = after.point.y - hit.point.y;
      const float dot = ax * bx + ay * by;
      event = dot <= cosTurn * std::sqrt((ax * ax + ay * ay) * (bx * bx + by * by));
    }
    if (!event) continue;
    any = true;
    // Intervals s - reach .. s + reach - 1 (interval i runs from sample i to sample i + 1).
    for (int i = s - reach; i < s + reach; ++i)
      refine_interval_[((i % samples) + samples) % samples] = 1;
  }
  return any;
}

void LineDetector::refineContour(const camera::FrameView& frame, ContourWork& w, float perMetre) {
  const int samples = w.samples;
  const float* su = &smooth_u_[w.smooth_begin];
  const float* sv = &smooth_v_[w.smooth_begin];
  w.merged_begin = merged_hits_.size();
  for (int s = 0; s < samples; ++s) {
    merged_hits_.push(hits_[w.hits_begin + s]);
    if (!refine_interval_[s]) continue;
    const float a = static_cast<float>(s * w.sample_step);
    const float b = s + 1 == samples ? static_cast<float>(w.smoothed)
                                     : static_cast<float>((s + 1) * w.sample_step);
    int extra = params_.refine_samples;
    if (perMetre > 0.0f) {
      // The interval's floor length: its chord through the floor's Jacobian at its middle.
      const int ia = static_cast<int>(a), ib = s + 1 == samples ? 0 : static_cast<int>(b);
      const float du = su[ib] - su[ia], dv = sv[ib] - sv[ia];
      const float metres = floorLength(su[ia] + 0.5f * du, sv[ia] + 0.5f * dv, du, dv);
      extra = std::min(extra, static_cast<int>(metres * perMetre));
      if (extra <= 0) continue;
    }
    const int first = merged_hits_.size();
    Hit* const scanned = merged_hits_.appendMisses(extra);
    for (int t = 1; t <= extra; ++t) {
      scanAt(frame, w, a + (b - a) * static_cast<float>(t) / static_cast<float>(extra + 1),
             scanned[t - 1]);
    }
    refined_.emplace_back(first, extra);
  }
  w.merged_count = merged_hits_.size() - w.merged_begin;
}

void LineDetector::groupSequences(LinePoints& out) {
  // Hits into sequences along each contour, starting after a miss so that a sequence crossing
  // the contour's start is not cut in two.
  for (const ContourWork& w : work_) {
    const bool merged = w.merged_begin >= 0;
    const Hit* ordered = merged ? &merged_hits_[w.merged_begin] : &hits_[w.hits_begin];
    const int total = merged ? w.merged_count : w.samples;
    int firstMiss = -1;
    for (int s = 0; s < total && firstMiss < 0; ++s) {
      if (!ordered[s].found) firstMiss = s;
    }
    const int begin = firstMiss < 0 ? 0 : firstMiss;
    int sequenceStart = -1;
    int misses = 0;
    auto close = [&] {
      const int end = static_cast<int>(out.points.size());
      if (sequenceStart >= 0 && end - sequenceStart >= 2) {
        out.sequences.emplace_back(sequenceStart, end);
      } else if (sequenceStart >= 0) {
        out.points.resize(sequenceStart);  // a lone point is more likely noise than a line
      }
      sequenceStart = -1;
    };
    // From `begin` round to it: no division per hit.
    for (int step = 0, at = begin; step < total; ++step, at = at + 1 == total ? 0 : at + 1) {
      const Hit& hit = ordered[at];
      if (hit.found) {
        if (sequenceStart < 0) sequenceStart = static_cast<int>(out.points.size());
        out.points.push_back(hit.point);
        misses = 0;
      } else if (sequenceStart >= 0 && ++misses > params_.max_gap_samples) {
        close();
      }
    }
    close();
  }
}

}  // namespace fieldline::region_tracking
