// Where the line detector scans along a contour: the contour's staircase smoothed into a curve,
// and (sample_spacing_m) samples placed by floor distance, denser near turns.
#include <algorithm>
#include <cmath>

#include "services/region_tracking/detector_pixels.hpp"
#include "services/region_tracking/line_detector.hpp"

namespace fieldline::region_tracking {

using detail::kCornerToPixel;
using detail::nearestPixel;

const LineDetector::Jacobian* LineDetector::jacobianNear(float u, float v) const {
  // Nearest cell corner: pixel u sits at corner (u + 0.5) / cell_size.
  const float inverseCell = 1.0f / static_cast<float>(cell_size_);
  const int i = nearestPixel((u - kCornerToPixel) * inverseCell);
  const int j = nearestPixel((v - kCornerToPixel) * inverseCell);
  if (i < 0 || j < 0 || i >= jacobian_columns_ || j >= jacobian_rows_) return nullptr;
  return &jacobians_[static_cast<std::size_t>(j) * jacobian_columns_ + i];
}

bool LineDetector::floorStep(float u, float v, float du, float dv, float& dx, float& dy) const {
  dx = dy = 0.0f;
  const Jacobian* near = jacobianNear(u, v);
  if (near == nullptr) return false;
  const Jacobian& jac = *near;
  const float x = jac.xu * du + jac.xv * dv;
  const float y = jac.yu * du + jac.yv * dv;
  if (!std::isfinite(x) || !std::isfinite(y)) return false;
  dx = x;
  dy = y;
  return true;
}

void LineDetector::measureSteps(const float* su, const float* sv, int n) {
  // The floor step of every corner step of the smoothed contour (step j: corner j to j + 1).
  step_x_.resize(n);
  step_y_.resize(n);
  step_length_.resize(n);
  for (int j = 0; j < n; ++j) {
    const int after = j + 1 == n ? 0 : j + 1;
    const float u = su[j], v = sv[j];
    const float du = su[after] - u, dv = sv[after] - v;
    floorStep(u + 0.5f * du, v + 0.5f * dv, du, dv, step_x_[j], step_y_[j]);
    step_length_[j] = std::sqrt(step_x_[j] * step_x_[j] + step_y_[j] * step_y_[j]);
  }
}

bool LineDetector::markNearTurns(const float* su, const float* sv, int n) {
  // Steps within turn_reach_m of a turn: the floor directions summed over the turn_span steps
  // before corner j and after it differ by more than turn_angle.
  const bool turns = params_.turn_spacing_m > 0.0 && n > 2 * params_.turn_span;
  if (!turns) return false;
  near_turn_.assign(n, 0);
  const int span = params_.turn_span;
  const float tanTurn = static_cast<float>(std::tan(std::min(params_.turn_angle, 1.5)));
  float bx = 0, by = 0, ax = 0, ay = 0;  // sums of the steps [j - span, j) and [j, j + span)
  for (int i = 0; i < span; ++i) {
    bx += step_x_[n - span + i];
    by += step_y_[n - span + i];
    ax += step_x_[i];
    ay += step_y_[i];
  }
  const float reach = static_cast<float>(params_.turn_reach_m);
  const float range2 = static_cast<float>(params_.turn_range_m * params_.turn_range_m);
  turn_.assign(n, 0);
  bool anyTurn = false;
  for (int j = 0; j < n; ++j) {
    const float dot = bx * ax + by * ay, cross = bx * ay - by * ax;
    if ((bx != 0.0f || by != 0.0f) && (ax != 0.0f || ay != 0.0f) &&
        (dot <= 0.0f || std::abs(cross) > tanTurn * dot)) {
      const Jacobian* near = jacobianNear(su[j], sv[j]);
      if (near != nullptr && near->range2 <= range2) {  // (NaN: no)
        turn_[j] = 1;
        anyTurn = true;
      }
    }
    // Slide both windows by one step.
    const int leaving = j - span < 0 ? j - span + n : j - span;
    const int entering = j + span >= n ? j + span - n : j + span;
    bx += step_x_[j] - step_x_[leaving];
    by += step_y_[j] - step_y_[leaving];
    ax += step_x_[entering] - step_x_[j];
    ay += step_y_[entering] - step_y_[j];
  }
  // The steps within `reach` of a turning corner, forward (steps j, j + 1, ...) and backward
  // (steps j - 1, j - 2, ...): two sweeps of twice around the closed contour, each carrying the
  // floor walked since the last turn.
  if (anyTurn) {
    float walked = reach;
    for (int k = 0; k < 2 * n; ++k) {
      const int i = k < n ? k : k - n;
      if (turn_[i]) walked = 0.0f;
      if (walked < reach) near_turn_[i] = 1;
      walked += step_length_[i];
    }
    walked = reach;
    for (int k = 2 * n - 1; k >= 0; --k) {
      const int i = k < n ? k : k - n;  // step i, from corner i to corner i + 1
      if (turn_[i + 1 == n ? 0 : i + 1]) walked = 0.0f;
      if (walked < reach) near_turn_[i] = 1;
      walked += step_length_[i];
    }
  }
  return true;
}

void LineDetector::sampleByDistance(const float* su, const float* sv, int n,
                                    std::vector<float>& positions) {
  positions.clear();
  measureSteps(su, sv, n);
  const bool turns = markNearTurns(su, sv, n);
  // Each corner step counts min(floor length / spacing, pixels / minimum pixels) samples; a
  // sample sits wherever the running count passes a whole number, at its fraction of the step.
  const float perMetre = static_cast<float>(1.0 / params_.sample_spacing_m);
  const float perMetreNearTurn =
      turns ? static_cast<float>(1.0 / params_.turn_spacing_m) : perMetre;
  const float perPixel = static_cast<float>(1.0 / params_.sample_min_px);
  float count = 0.0f;  // samples before corner j (running, fractional)
  float next = 0.0f;   // count at which the next sample falls
  for (int j = 0; j < n; ++j) {
    const int after = j + 1 == n ? 0 : j + 1;
    const float du = su[after] - su[j], dv = sv[after] - sv[j];
    const float pixels = std::sqrt(du * du + dv * dv);
    if (step_length_[j] <= 0.0f) continue;  // no floor there
    const float units =
        std::min(step_length_[j] * (turns && near_turn_[j] ? perMetreNearTurn : perMetre),
                 pixels * perPixel);
    if (units <= 0.0f) continue;
    const float end = count + units;
    while (next < end) {
      positions.push_back(static_cast<float>(j) + (next - count) / units);
      next += 1.0f;
    }
    count = end;
  }
}

void LineDetector::smoothedPoint(int i, float& u, float& v) const {
  // padded_u_[j] holds corner j - pad_; the kernel is centred on corner i.
  const int taps = static_cast<int>(smoothing_kernel_.size());
  const int reach = taps / 2;
  const float* pu = &padded_u_[i + pad_ - reach];
  const float* pv = &padded_v_[i + pad_ - reach];
  const float* weight = smoothing_kernel_.data();
  float su = 0, sv = 0;
  for (int j = 0; j < taps; ++j) {
    su += weight[j] * pu[j];
    sv += weight[j] * pv[j];
  }
  u = su + kCornerToPixel;
  v = sv + kCornerToPixel;
}

void LineDetector::smoothContour(const ContourPoint* corners, int n, int stride, float* su,
                                 float* sv) {
  const int smoothed = n / stride;
  if (smoothing_kernel_.size() == 7) {
    // Three passes: the kernel is 1 6 15 20 15 6 1 over 64. Summed in integers and scaled once:
    // the same points bit for bit as the float sums over the padded corners (every term there
    // is a multiple of 1/64 far below 2^24, so no float operation rounds), without the copy.
    const auto at = [&](int i) -> const ContourPoint& {
      return corners[i < 0 ? i + n * ((-i + n - 1) / n) : (i >= n ? i % n : i)];
    };
    constexpr float kScale = 1.0f / 64.0f;
    for (int j = 0; j < smoothed; ++j) {
      const int i = j * stride;
      int x, y;
      if (i >= 3 && i + 3 < n) {
        const ContourPoint* c = corners + i;
        x = (c[-3].x + c[3].x) + 6 * (c[-2].x + c[2].x) + 15 * (c[-1].x + c[1].x) + 20 * c[0].x;
        y = (c[-3].y + c[3].y) + 6 * (c[-2].y + c[2].y) + 15 * (c[-1].y + c[1].y) + 20 * c[0].y;
      } else {
        x = (at(i - 3).x + at(i + 3).x) + 6 * (at(i - 2).x + at(i + 2).x) +
            15 * (at(i - 1).x + at(i + 1).x) + 20 * at(i).x;
        y = (at(i - 3).y + at(i + 3).y) + 6 * (at(i - 2).y + at(i + 2).y) +
            15 * (at(i - 1).y + at(i + 1).y) + 20 * at(i).y;
      }
      su[j] = static_cast<float>(x) * kScale + kCornerToPixel;
      sv[j] = static_cast<float>(y) * kScale + kCornerToPixel;
    }
    return;
  }
  // Any other kernel: the corners with the kernel's and the tangent's reach wrapped around on
  // both sides.
  padded_u_.resize(n + 2 * pad_);
  padded_v_.resize(n + 2 * pad_);
  for (int j = 0; j < n; ++j) {
    padded_u_[pad_ + j] = static_cast<float>(corners[j].x);
    padded_v_[pad_ + j] = static_cast<float>(corners[j].y);
  }
  for (int j = 0; j < pad_; ++j) {  // the wrapped ends (the contour may be shorter than pad_)
    const int before = ((j - pad_) % n + n) % n;
    padded_u_[j] = static_cast<float>(corners[before].x);
    padded_v_[j] = static_cast<float>(corners[before].y);
    padded_u_[pad_ + n + j] = static_cast<float>(corners[j % n].x);
    padded_v_[pad_ + n + j] = static_cast<float>(corners[j % n].y);
  }
  for (int j = 0; j < smoothed; ++j)
    smoothedPoint(j * stride, su[j], sv[j]);
}

}  // namespace fieldline::region_tracking
