#include "services/feature_recognition/unseen_lines.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace fieldline::feature_recognition {

using geometry::Vec2;

namespace {
constexpr double kStep = 0.05;  // m between the model's samples
constexpr double kCell = 0.1;   // m, the cells of the "a point near" map
}  // namespace

UnseenLines::UnseenLines(const field::FieldModel& field, const RecognitionParams& params)
    : range_(params.unseen_range),
      min_range_(params.unseen_min_range),
      cover_(params.unseen_cover),
      beyond_(params.unseen_beyond),
      max_stretch_(params.unseen_max_stretch),
      cell_(kCell) {
  if (!(range_ > 0.0) || !(min_range_ >= 0.0 && min_range_ < range_) || !(cover_ > 0.0) ||
      !(beyond_ >= 0.0) || !(params.unseen_bearing_bin > 0.0 && params.unseen_bearing_bin < 1.0)) {
    throw std::invalid_argument(
        "UnseenLines: unseen_range, unseen_cover and unseen_bearing_bin (< 1 rad) must be "
        "positive, unseen_min_range in [0, unseen_range), unseen_beyond >= 0");
  }
  for (const field::LineSegment& s : field.segments()) {
    const int n = std::max(1, static_cast<int>(std::ceil(s.length() / kStep)));
    elements_.push_back({static_cast<int>(samples_.size()), n, s.length() / n, 0.5 * (s.a + s.b),
                         0.5 * s.length(), true, false, s.a, s.b});
    for (int i = 0; i <= n; ++i)
      samples_.push_back(s.a + (s.b - s.a) * (static_cast<double>(i) / n));
  }
  for (const field::LineArc& a : field.arcs()) {
    const int n = std::max(1, static_cast<int>(std::ceil(a.radius * a.sweep / kStep)));
    const bool closed = a.sweep >= 2.0 * std::numbers::pi - 1e-9;
    elements_.push_back({static_cast<int>(samples_.size()), n, a.radius * a.sweep / n, a.centre,
                         a.radius, false, closed});
    for (int i = 0; i <= n; ++i)
      samples_.push_back(a.pointAt(a.start_angle + a.sweep * (static_cast<double>(i) / n)));
  }
  inverse_cell_ = 1.0 / cell_;
  half_extent_ = range_ + cover_ + cell_;
  side_ = static_cast<int>(std::ceil(2.0 * half_extent_ / cell_));
  near_.assign(static_cast<std::size_t>(side_) * side_, 0);
  has_point_.assign(near_.size(), 0);
  // The stamp of "a point near": the cells whose centres lie within cover_ of the point's cell
  // centre, as a half width per row.
  const double radius = cover_ / cell_;
  const int reach = static_cast<int>(std::floor(radius + 1e-9));
  for (int dj = -reach; dj <= reach; ++dj) {
    stamp_.push_back(static_cast<int>(std::floor(std::sqrt(radius * radius - dj * dj) + 1e-9)));
  }
  bins_ = static_cast<int>(std::ceil(2.0 * std::numbers::pi / params.unseen_bearing_bin));
  furthest_.assign(static_cast<std::size_t>(bins_), 0.0f);
}

namespace {
// atan2 within 2e-4 rad (a minimax polynomial on [0, 1] and the octant's symmetries): the
// bearing bins need no more, and libm's atan2 was a fifth of the check's time.
inline float quickAtan2(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float big = std::max(ax, ay);
  if (big == 0.0f) return 0.0f;
  const float a = std::min(ax, ay) / big;
  const float s = a * a;
  float r = ((-0.0464964749f * s + 0.15931422f) * s - 0.327622764f) * s * a + a;
  if (ay > ax) r = std::numbers::pi_v<float> / 2 - r;
  if (x < 0.0f) r = std::numbers::pi_v<float> - r;
  return y < 0.0f ? -r : r;
}
}  // namespace

int UnseenLines::binOf(float x, float y) const {
  constexpr float kPi = std::numbers::pi_v<float>;
  const float bearing = quickAtan2(y, x) + kPi;
  return std::min(bins_ - 1, static_cast<int>(bearing / (2.0f * kPi) * static_cast<float>(bins_)));
}

void UnseenLines::index(const std::vector<Vec2>& points) {
  // A new generation instead of clearing the maps (cleared only when it wraps).
  if (++generation_ == 0) {
    std::fill(near_.begin(), near_.end(), 0);
    std::fill(has_point_.begin(), has_point_.end(), 0);
    generation_ = 1;
  }
  std::fill(furthest_.begin(), furthest_.end(), 0.0f);
  const int reach = static_cast<int>(stamp_.size() / 2);
  for (const Vec2& p : points) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y())) continue;
    const float x = static_cast<float>(p.x()), y = static_cast<float>(p.y());
    const float range = std::sqrt(x * x + y * y);
    float& furthest = furthest_[binOf(x, y)];
    furthest = std::max(furthest, range);
    const int cell = cellOf(p.x(), p.y());
    // Points are dense along lines: a cell stamped once needs no second stamp.
    if (cell < 0 || has_point_[cell] == generation_) continue;
    has_point_[cell] = generation_;
    const int ci = cell % side_, cj = cell / side_;
    for (int dj = -reach; dj <= reach; ++dj) {
      const int j = cj + dj;
      if (j < 0 || j >= side_) continue;
      const int half = stamp_[dj + reach];
      const int i0 = std::max(0, ci - half), i1 = std::min(side_ - 1, ci + half);
      std::fill_n(near_.begin() + static_cast<std::ptrdiff_t>(j) * side_ + i0, i1 - i0 + 1,
                  generation_);
    }
  }
}

bool UnseenLines::nearAt(double x, double y) const {
  const int cell = cellOf(x, y);
  return cell >= 0 && near_[cell] == generation_;
}

bool UnseenLines::clearTo(double x, double y, double range) const {
  return furthest_[binOf(static_cast<float>(x), static_cast<float>(y))] >= range + beyond_;
}

double UnseenLines::longestUnseen(const geometry::Pose2& robot) const {
  if (!geometry::isFinite(robot)) return 0.0;
  const double c = std::cos(robot.phi), s = std::sin(robot.phi);
  const double min2 = min_range_ * min_range_, max2 = range_ * range_;
  const Vec2 at = robot.position();
  double longest = 0.0;
  for (const Element& e : elements_) {
    // An element wholly out of range has nothing to say (its runs end at its ends anyway).
    if ((e.centre - at).norm() > range_ + e.radius) continue;
    // Of a segment, only its samples within range (a chord of the range's circle): those
    // before and after it would only end runs.
    int first = 0, last = e.closed ? e.intervals - 1 : e.intervals;  // a circle's seam once
    if (e.straight) {
      const Vec2 d = e.b - e.a, f = e.a - at;
      const double qa = d.squaredNorm(), qb = 2.0 * f.dot(d), qc = f.squaredNorm() - max2;
      const double disc = qb * qb - 4.0 * qa * qc;
      if (!(disc >= 0.0) || !(qa > 0.0)) continue;
      const double root = std::sqrt(disc);
      const double t0 = (-qb - root) / (2.0 * qa), t1 = (-qb + root) / (2.0 * qa);
      if (t1 < 0.0 || t0 > 1.0) continue;
      // One sample of slack each way: the range test below stays the judge.
      first = std::max(0, static_cast<int>(std::floor(std::max(t0, 0.0) * e.intervals)) - 1);
      last =
          std::min(e.intervals, static_cast<int>(std::ceil(std::min(t1, 1.0) * e.intervals)) + 1);
    }
    double run = 0.0, leading = -1.0;  // leading: the run from the first sample (closed arcs)
    for (int k = e.begin + first; k <= e.begin + last; ++k) {
      const double dx = samples_[k].x() - robot.x, dy = samples_[k].y() - robot.y;
      const double x = c * dx + s * dy, y = -s * dx + c * dy;
      const double range2 = x * x + y * y;
      // The cheap tests first: most samples are out of range or have a point near them.
      const bool unseen =
          range2 >= min2 && range2 <= max2 && !nearAt(x, y) && clearTo(x, y, std::sqrt(range2));
      if (!unseen && leading < 0.0) leading = run;
      run = unseen ? run + e.spacing : 0.0;
      longest = std::max(longest, run);
    }
    // A closed circle's run may go on across its seam: its end joins its start.
    if (e.closed) longest = std::max(longest, leading < 0.0 ? run : run + leading);
  }
  return longest;
}

}  // namespace fieldline::feature_recognition
