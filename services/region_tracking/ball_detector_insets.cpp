#include "services/region_tracking/ball_detector_insets.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <utility>
#include <variant>
#include <vector>

namespace fieldline::region_tracking {

namespace {
// No ball is placed farther than this (m; an MSL field's diagonal is about 22 m).
constexpr double kMaxM = 25.0;
// The outermost pixel centres lie within kBand px of an edge: only pixels there are tested.
constexpr double kBand = 4.0;
int angleBin(const camera::Vec2& direction) {
  const double folded = std::atan2(std::abs(direction.y()), std::abs(direction.x()));
  return std::min(EdgeInsetTable::kAngleBins - 1,
                  static_cast<int>(folded / (0.5 * std::numbers::pi) * EdgeInsetTable::kAngleBins));
}
}  // namespace

EdgeInsetTable::EdgeInsetTable(const camera::MirrorModel& mirror, double centreHeight)
    : mirror_(mirror), centre_height_(centreHeight) {
  // Knots from the nearest ball the mirror shows to one whose near edge is beyond the useful
  // radius.
  const camera::MirrorParams& mp = mirror_.params();
  first_m_ = std::max(mp.distance.floorDistance(mp.self_radius, 0.0), 0.0) + centre_height_;
  double last = first_m_;
  for (int k = 0; k < 8; ++k) {
    last = std::max(last, mp.distance.floorDistance(
                              std::min(mp.useful_radius, mp.distance.maxRadius()), k * 0.785));
  }
  // A mirror that images the horizon has no far end: a ball beyond the field's diagonal is never
  // placed, so the table stops there (and at two knots at least, for the interpolation).
  if (!std::isfinite(last) || last > kMaxM) last = kMaxM;
  if (!std::isfinite(first_m_) || first_m_ > last) first_m_ = 0.0;
  knots_ = std::max(2, static_cast<int>(std::ceil((last + 0.5 - first_m_) / kStepM)) + 1);
  for (int j = 0; j < kSamples; ++j) {
    sample_bins_[j] = angleBin(mirror_.imageDirection(sampleBearing(j)));
  }
  cells_ = std::make_unique<Cell[]>(static_cast<std::size_t>(kAngleBins * knots_));
}

double EdgeInsetTable::sampleBearing(int sample) {
  return 2 * std::numbers::pi * (sample + 0.5) / kSamples + 0.1;
}

double EdgeInsetTable::sampleOffset(int sample) {
  return sample * 0.6180339887 - std::floor(sample * 0.6180339887) - 0.5;
}

int EdgeInsetTable::cellsSampled() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  int n = 0;
  for (int i = 0; i < kAngleBins * knots_; ++i)
    n += cells_[i].sampled ? 1 : 0;
  return n;
}

const EdgeInsetTable::Cell& EdgeInsetTable::sampled(int bin, int knot) const {
  // The knot's spheres of this angle bin, in the order of their bearings.
  Cell& cell = cells_[bin * knots_ + knot];
  if (cell.sampled) return cell;
  for (int j = 0; j < kSamples; ++j) {
    if (sample_bins_[j] != bin) continue;
    EdgeInsets plain, pairs;
    if (!sampleInsets(first_m_ + (knot + sampleOffset(j)) * kStepM, sampleBearing(j), plain,
                      pairs)) {
      continue;
    }
    for (int yuyv = 0; yuyv < 2; ++yuyv) {
      const EdgeInsets& e = yuyv ? pairs : plain;
      Sum& sum = cell.sums[yuyv];
      sum.near += e.near_px;
      ++sum.near_n;
      if (std::isfinite(e.far_px)) {
        sum.far += e.far_px;
        ++sum.far_n;
      }
    }
  }
  cell.sampled = true;
  return cell;
}

void EdgeInsetTable::resolve(int bin, int knot) const {
  // Each edge on its own: this knot's mean, else the nearest nearer knot's, else the nearest
  // farther knot's, else half a pixel (the eager table's backward-then-forward carry gave the
  // same).
  Cell& cell = cells_[bin * knots_ + knot];
  for (int yuyv = 0; yuyv < 2; ++yuyv) {
    for (const bool nearEdge : {true, false}) {
      const auto from = [&](int k, double& out) {
        // A knot none of whose spheres can show a far edge adds none: not scanned for it.
        if (!nearEdge && !mayShowFarEdge(bin, k)) return false;
        const Sum& s = sampled(bin, k).sums[yuyv];
        const int n = nearEdge ? s.near_n : s.far_n;
        if (n > 0) out = (nearEdge ? s.near : s.far) / n;
        return n > 0;
      };
      double value = 0.5;
      bool found = false;
      for (int k = knot; k >= 0 && !found; --k)
        found = from(k, value);
      for (int k = knot + 1; k < knots_ && !found; ++k)
        found = from(k, value);
      (nearEdge ? cell.value[yuyv].near_px : cell.value[yuyv].far_px) = value;
    }
  }
  cell.resolved.store(true, std::memory_order_release);
}

const EdgeInsetTable::Cell& EdgeInsetTable::resolved(int bin, int knot) const {
  const Cell& cell = cells_[bin * knots_ + knot];
  if (!cell.resolved.load(std::memory_order_acquire)) {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!cell.resolved.load(std::memory_order_relaxed)) resolve(bin, knot);
  }
  return cell;
}

EdgeInsets EdgeInsetTable::cell(int bin, int knot, bool yuyv) const {
  return resolved(bin, knot).value[yuyv ? 1 : 0];
}

EdgeInsets EdgeInsetTable::at(double horizontal, double bearing, bool yuyv) const {
  if (!std::isfinite(horizontal) || !std::isfinite(bearing)) return EdgeInsets{};
  const double x = std::clamp((horizontal - first_m_) / kStepM, 0.0, knots_ - 1.0);
  const int k0 = std::min(static_cast<int>(x), knots_ - 2);
  const double fk = x - k0;
  const camera::Vec2 dir = mirror_.imageDirection(bearing);
  const double a = std::clamp(
      std::atan2(std::abs(dir.y()), std::abs(dir.x())) / (0.5 * std::numbers::pi) * kAngleBins -
          0.5,
      0.0, kAngleBins - 1.0);
  const int a0 = std::min(static_cast<int>(a), kAngleBins - 2);
  const double fa = a - a0;
  EdgeInsets out{0, 0};
  for (int da = 0; da < 2; ++da) {
    for (int dk = 0; dk < 2; ++dk) {
      const double w = (da ? fa : 1 - fa) * (dk ? fk : 1 - fk);
      const EdgeInsets& e = resolved(a0 + da, k0 + dk).value[yuyv ? 1 : 0];
      out.near_px += w * e.near_px;
      out.far_px += w * e.far_px;
    }
  }
  return out;
}

EdgeInsetTable::EdgeRadii EdgeInsetTable::edgeRadii(double horizontal, double bearing) const {
  const camera::MirrorParams& mp = mirror_.params();
  const double H = mp.reference_height, r = centre_height_;
  // The grazing rays from R in the vertical plane through the centre: depression alpha +- beta.
  const double alpha = std::atan2(H - r, horizontal);
  const double beta = std::asin(std::min(1.0, r / std::hypot(horizontal, H - r)));
  return {mp.distance.imageRadius(H / std::tan(alpha + beta), bearing),
          alpha > beta ? mp.distance.imageRadius(H / std::tan(alpha - beta), bearing)
                       : std::numeric_limits<double>::quiet_NaN()};
}

bool EdgeInsetTable::mayShowFarEdge(int bin, int knot) const {
  // sampleInsets gives a far inset exactly where the near edge is imaged and the far edge is
  // within the distance function: the same test without the pixel scan.
  for (int j = 0; j < kSamples; ++j) {
    if (sample_bins_[j] != bin) continue;
    const EdgeRadii e = edgeRadii(first_m_ + (knot + sampleOffset(j)) * kStepM, sampleBearing(j));
    if (std::isfinite(e.near) && e.near >= mirror_.params().self_radius && std::isfinite(e.far)) {
      return true;
    }
  }
  return false;
}

// long: the pixel test and the two edge bands' scan belong together
bool EdgeInsetTable::sampleInsets(double horizontal, double bearing, EdgeInsets& plain,
                                  EdgeInsets& pairs) const {
  const camera::MirrorParams& mp = mirror_.params();
  const double H = mp.reference_height, r = centre_height_;
  const EdgeRadii radii = edgeRadii(horizontal, bearing);
  const double nearR = radii.near, farR = radii.far;
  if (!std::isfinite(nearR) || nearR < mp.self_radius) return false;
  const bool hasFar = std::isfinite(farR);
  const double halfSpan = std::asin(std::min(1.0, r / horizontal)) + 2.0 / nearR;
  const camera::Vec3 centre(horizontal * std::cos(bearing), horizontal * std::sin(bearing), r);
  const camera::Vec3 w0 = camera::Vec3(0, 0, H) - centre;
  // Does the ray through pixel (u, v)'s centre meet the sphere (what a pixel shows)?
  const auto hits = [&](int u, int v) {
    const camera::Vec2 pixel(u, v);
    const double b = mirror_.bearingOf(pixel);
    const double floor = mp.distance.floorDistance(mirror_.radiusOf(pixel), b);
    if (!std::isfinite(floor)) return false;
    const camera::Vec3 dir(floor * std::cos(b), floor * std::sin(b), -H);
    const double bh = dir.dot(w0);
    return bh * bh - dir.squaredNorm() * (w0.squaredNorm() - r * r) >= 0.0;
  };
  double nearPlain = std::numeric_limits<double>::infinity(), nearPair = nearPlain;
  double farPlain = -1, farPair = -1;
  // One pixel of a band (inner <= radius <= outer). The extremes do not depend on the order.
  const auto visit = [&](int u, int v, double inner, double outer) {
    const double radius = mirror_.radiusOf(camera::Vec2(u, v));
    if (radius < inner || radius > outer || !hits(u, v)) return;
    nearPlain = std::min(nearPlain, radius);
    farPlain = std::max(farPlain, radius);
    // The pixel sharing this one's chroma in a YUYV frame (columns 2k and 2k + 1), looked
    // at only where it could move an extreme.
    if ((radius < nearPair || radius > farPair) && hits(u % 2 == 0 ? u + 1 : u - 1, v)) {
      nearPair = std::min(nearPair, radius);
      farPair = std::max(farPair, radius);
    }
  };
  // Each band's pixels: the box of the band across the bearings the ball spans; in each row only
  // the columns whose radius can lie in the band (a pixel wider on each side), so that the work
  // grows with the band's area, not the box's.
  for (int band = 0; band < (hasFar ? 2 : 1); ++band) {
    const double inner = band == 0 ? nearR - 1.5 : farR - kBand;
    const double outer = band == 0 ? nearR + kBand : farR + 1.5;
    double minU = 1e9, maxU = -1e9, minV = 1e9, maxV = -1e9;
    for (const double radius : {inner, outer}) {
      for (const double b : {bearing - halfSpan, bearing, bearing + halfSpan}) {
        const camera::Vec2 p = mp.centre + radius * mirror_.imageDirection(b);
        minU = std::min(minU, p.x());
        maxU = std::max(maxU, p.x());
        minV = std::min(minV, p.y());
        maxV = std::max(maxV, p.y());
      }
    }
    const int u0 = static_cast<int>(std::floor(minU)) - 1, u1 = static_cast<int>(maxU) + 1;
    const double cu = mp.centre.x(), wide = outer + 1.0, hole = inner - 1.0;
    for (int v = static_cast<int>(std::floor(minV)) - 1; v <= static_cast<int>(maxV) + 1; ++v) {
      const double dv = v - mp.centre.y();
      if (std::abs(dv) > wide) continue;
      const double ho = std::sqrt(wide * wide - dv * dv);
      const double hi = hole > std::abs(dv) ? std::sqrt(hole * hole - dv * dv) : -1.0;
      // Columns with |u - cu| in [hi, ho]: left of the centre, then right of it.
      const int leftEnd = std::min(u1, static_cast<int>(std::ceil(cu - hi)));
      for (int u = std::max(u0, static_cast<int>(std::floor(cu - ho))); u <= leftEnd; ++u) {
        visit(u, v, inner, outer);
      }
      const int rightEnd = std::min(u1, static_cast<int>(std::ceil(cu + ho)));
      for (int u = std::max({u0, leftEnd + 1, static_cast<int>(std::floor(cu + hi))});
           u <= rightEnd; ++u) {
        visit(u, v, inner, outer);
      }
    }
  }
  if (!std::isfinite(nearPair)) return false;
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  plain = {nearPlain - nearR, hasFar ? farR - farPlain : kNaN};
  pairs = {nearPair - nearR, hasFar ? farR - farPair : kNaN};
  return true;
}

namespace {
// Every parameter the table depends on, bit for bit. A field added to MirrorParams or the
// distance function's parameters must be added here.
std::vector<std::uint64_t> tableKey(const camera::MirrorModel& mirror, double centreHeight) {
  const camera::MirrorParams& p = mirror.params();
  std::vector<std::uint64_t> key;
  const auto add = [&key](double x) { key.push_back(std::bit_cast<std::uint64_t>(x)); };
  for (const double x :
       {centreHeight, static_cast<double>(p.width), static_cast<double>(p.height), p.centre.x(),
        p.centre.y(), p.heading_angle, p.mirrored ? 1.0 : 0.0, p.outer_radius, p.useful_radius,
        p.self_radius, p.reference_height, p.axis_offset.x(), p.axis_offset.y()}) {
    add(x);
  }
  if (const auto* le = std::get_if<camera::LinearExponentialParams>(&p.distance.params())) {
    for (const double x : {0.0, le->slope, le->knee_radius, le->growth})
      add(x);
    return key;
  }
  const auto& table = std::get<camera::CalibrationTableParams>(p.distance.params());
  add(1.0);
  add(static_cast<double>(table.radii.size()));
  for (const double x : table.radii)
    add(x);
  add(static_cast<double>(table.sector_bearings.size()));
  for (const double x : table.sector_bearings)
    add(x);
  for (const std::vector<double>& sector : table.distances) {
    add(static_cast<double>(sector.size()));
    for (const double x : sector)
      add(x);
  }
  return key;
}
}  // namespace

std::shared_ptr<const EdgeInsetTable> edgeInsetTableFor(const camera::MirrorModel& mirror,
                                                        double centreHeight) {
  // The most recently used first; a few mirrors at most in a process (a node's frame sizes, a
  // tool's or a test's cameras).
  constexpr std::size_t kKept = 8;
  using Entry = std::pair<std::vector<std::uint64_t>, std::shared_ptr<const EdgeInsetTable>>;
  static std::mutex mutex;
  static std::vector<Entry> kept;
  std::vector<std::uint64_t> key = tableKey(mirror, centreHeight);
  const std::lock_guard<std::mutex> lock(mutex);
  auto found = std::find_if(kept.begin(), kept.end(),
                            [&key](const Entry& entry) { return entry.first == key; });
  if (found == kept.end()) {
    if (kept.size() >= kKept) kept.pop_back();
    kept.insert(kept.begin(),
                Entry{std::move(key), std::make_shared<EdgeInsetTable>(mirror, centreHeight)});
  } else {
    std::rotate(kept.begin(), found, found + 1);
  }
  return kept.front().second;
}

}  // namespace fieldline::region_tracking
