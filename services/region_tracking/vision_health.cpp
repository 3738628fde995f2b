#include "services/region_tracking/vision_health.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

namespace fieldline::region_tracking {

namespace {
// Empty when the coverage grid of `p` is within kMaxRangeOverCoverage, else why not.
std::string coverageGridProblem(const VisionHealthParams& p) {
  if (!(p.field_range_m > 0.0 && p.coverage_distance_m > 0.0 && std::isfinite(p.field_range_m))) {
    return "field_range_m and coverage_distance_m must be finite and > 0";
  }
  const double ratio = p.field_range_m / p.coverage_distance_m;
  if (ratio <= kMaxRangeOverCoverage * (1.0 + 1e-12)) return {};
  const double side = 2.0 * (std::ceil(ratio) + 2.0) + 1.0;
  return fmt::format(
      "coverage_distance_m {} is too fine for field_range_m {}: the coverage grid would take "
      "{:.1f} "
      "MB (field_range_m / coverage_distance_m at most {:.0f}: coverage_distance_m >= {} here)",
      p.coverage_distance_m, p.field_range_m, side * side / 1e6, kMaxRangeOverCoverage,
      p.field_range_m / kMaxRangeOverCoverage);
}
}  // namespace

VisionHealthParams loadVisionHealthParams(const config::Node& n) {
  VisionHealthParams p;
  p.window_frames = n.getOr<int>("window_frames", p.window_frames, 1, 10000);
  p.min_green_fraction = n.getOr<double>("min_green_fraction", p.min_green_fraction, 0.0, 1.0);
  p.max_orange_fraction = n.getOr<double>("max_orange_fraction", p.max_orange_fraction, 0.0, 1.0);
  p.max_line_frames_without_points =
      n.getOr<int>("max_line_frames_without_points", p.max_line_frames_without_points, 1, 100000);
  p.max_search_fraction = n.getOr<double>("max_search_fraction", p.max_search_fraction, 0.0, 1.0);
  p.sample_stride = n.getOr<int>("sample_stride", p.sample_stride, 1, 64);
  p.field_window_frames = n.getOr<int>("field_window_frames", p.field_window_frames, 1, 10000);
  p.field_range_m = n.getOr<double>("field_range_m", p.field_range_m, 0.5, 20.0);
  p.off_line_m = n.getOr<double>("off_line_m", p.off_line_m, 0.01, 5.0);
  p.max_off_line_share = n.getOr<double>("max_off_line_share", p.max_off_line_share, 0.0, 1.0);
  p.max_off_field_share = n.getOr<double>("max_off_field_share", p.max_off_field_share, 0.0, 1.0);
  p.max_green_beyond_share =
      n.getOr<double>("max_green_beyond_share", p.max_green_beyond_share, 0.0, 1.0);
  p.min_line_coverage = n.getOr<double>("min_line_coverage", p.min_line_coverage, 0.0, 1.0);
  p.coverage_distance_m = n.getOr<double>("coverage_distance_m", p.coverage_distance_m, 0.01, 2.0);
  p.min_field_points = n.getOr<int>("min_field_points", p.min_field_points, 1, 1000000);
  p.min_beyond_samples = n.getOr<int>("min_beyond_samples", p.min_beyond_samples, 1, 1000000);
  p.min_line_in_view_m = n.getOr<double>("min_line_in_view_m", p.min_line_in_view_m, 0.1, 1000.0);
  p.max_pose_sigma_m = n.getOr<double>("max_pose_sigma_m", p.max_pose_sigma_m, 0.01, 10.0);
  n.rejectUnknownKeys();
  if (const std::string problem = coverageGridProblem(p); !problem.empty()) {
    n.fail(n.has("coverage_distance_m") ? "coverage_distance_m" : "field_range_m", problem);
  }
  return p;
}

VisionHealth::VisionHealth(const camera::MirrorModel& mirror, const camera::ColourTable& table,
                           const VisionHealthParams& params, const field::FieldModel* field,
                           const ClassLookup* lookup)
    : table_(table), lookup_(lookup), mirror_(mirror), field_(field), params_(params) {
  if (params_.window_frames < 1 || params_.sample_stride < 1 ||
      params_.max_line_frames_without_points < 1 || params_.field_window_frames < 1) {
    throw std::invalid_argument(
        "vision health: window_frames, field_window_frames, sample_stride and "
        "max_line_frames_without_points must be >= 1");
  }
  if (const std::string problem = coverageGridProblem(params_); !problem.empty()) {
    throw std::invalid_argument("vision health: " + problem);
  }
  const int s = params_.sample_stride;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (mirror.width() > 65536 || mirror.height() > 65536) {
    throw std::invalid_argument("vision health: images up to 65536 px a side");
  }
  for (int v = s / 2; v < mirror.height(); v += s) {
    for (int u = s / 2; u < mirror.width(); u += s) {
      if (mirror.dontTouch(u, v)) continue;
      const auto floor = mirror.imageToRobot(camera::Vec2(u, v));
      // The floor point the pixel sees, robot frame (NaN: none).
      const float x = floor ? static_cast<float>(floor->x()) : nan;
      const float y = floor ? static_cast<float>(floor->y()) : nan;
      const geometry::Vec2 robot(x, y);
      if (robot.allFinite() && !(robot.norm() > params_.field_range_m)) {
        in_range_samples_.push_back({x, y, static_cast<std::uint32_t>(samples_.size())});
      }
      samples_.push_back({static_cast<std::uint16_t>(u), static_cast<std::uint16_t>(v)});
    }
  }
  if (samples_.empty()) throw std::invalid_argument("vision health: no floor pixel to sample");
  sample_classes_.resize(samples_.size(), camera::ColourClass::kUnknown);
  window_.resize(static_cast<std::size_t>(params_.window_frames));
  field_window_.resize(static_cast<std::size_t>(params_.field_window_frames));
  // The coverage bins: a sample within range lies in a bin within ceil(range / cell) of the
  // robot, its neighbours one further; one more for rounding.
  bin_half_ = static_cast<int>(std::ceil(params_.field_range_m / params_.coverage_distance_m)) + 2;
  const auto bin_side = static_cast<std::size_t>(2 * bin_half_ + 1);
  bins_.assign(bin_side * bin_side, 0);
  if (field_) bucketLineSamples(field_->sampleLines(line_sample_m_));
}

void VisionHealth::bucketLineSamples(const std::vector<geometry::Vec2>& samples) {
  if (samples.empty()) return;
  geometry::Vec2 lo = samples.front(), hi = samples.front();
  for (const geometry::Vec2& s : samples) {
    lo = lo.cwiseMin(s);
    hi = hi.cwiseMax(s);
  }
  line_origin_ = lo;
  line_columns_ = static_cast<int>(std::floor((hi.x() - lo.x()) / line_bucket_m_)) + 1;
  line_rows_ = static_cast<int>(std::floor((hi.y() - lo.y()) / line_bucket_m_)) + 1;
  const auto bucketOf = [&](const geometry::Vec2& s) {
    const int column = std::min(line_columns_ - 1,
                                static_cast<int>(std::floor((s.x() - lo.x()) / line_bucket_m_)));
    const int row =
        std::min(line_rows_ - 1, static_cast<int>(std::floor((s.y() - lo.y()) / line_bucket_m_)));
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(line_columns_) +
           static_cast<std::size_t>(column);
  };
  // A counting sort by square, each square's samples in their order.
  const std::size_t buckets =
      static_cast<std::size_t>(line_columns_) * static_cast<std::size_t>(line_rows_);
  std::vector<std::size_t> counts(buckets + 1, 0);
  for (const geometry::Vec2& s : samples)
    ++counts[bucketOf(s) + 1];
  for (std::size_t b = 0; b < buckets; ++b)
    counts[b + 1] += counts[b];
  line_buckets_.resize(buckets);
  for (std::size_t b = 0; b < buckets; ++b)
    line_buckets_[b] = {counts[b], counts[b + 1]};
  line_samples_.resize(samples.size());
  for (const geometry::Vec2& s : samples)
    line_samples_[counts[bucketOf(s)]++] = s;
}

namespace {
// geometry::pointRobotToField and pointFieldToRobot for one pose, with its sine and cosine taken
// once per frame instead of once per point (they were a third of the field checks' time, which
// were a fifth of the process's). The same arithmetic in the same order: the same results.
class PoseTransform {
 public:
  explicit PoseTransform(const geometry::Pose2& pose)
      : position_(pose.position()),
        cos_(std::cos(pose.phi)),
        sin_(std::sin(pose.phi)),
        cos_back_(std::cos(-pose.phi)),
        sin_back_(std::sin(-pose.phi)) {}
  geometry::Vec2 toField(const geometry::Vec2& robot) const {
    return position_ +
           geometry::Vec2(cos_ * robot.x() - sin_ * robot.y(), sin_ * robot.x() + cos_ * robot.y());
  }
  geometry::Vec2 toRobot(const geometry::Vec2& field) const {
    const geometry::Vec2 d = field - position_;
    return geometry::Vec2(cos_back_ * d.x() - sin_back_ * d.y(),
                          sin_back_ * d.x() + cos_back_ * d.y());
  }

 private:
  geometry::Vec2 position_;
  double cos_, sin_, cos_back_, sin_back_;
};
}  // namespace

void VisionHealth::selectNearbyLines(const geometry::Vec2& centre, double range, double reach) {
  // A line further than range + reach from the centre is further than reach from every point
  // checked; 1 cm more so that rounding can never leave out one that counts. Keeping only the
  // others (a few of the field's 20-odd) leaves fartherThan's answer exactly as it was.
  const double keep = range + reach + 0.01;
  near_segments_.clear();
  for (const field::LineSegment& s : field_->segments()) {
    if ((centre - field::closestPointOnSegment(s, centre)).norm() <= keep) {
      near_segments_.push_back(&s);
    }
  }
  near_arcs_.clear();
  for (const field::LineArc& a : field_->arcs()) {
    if ((centre - field::closestPointOnArc(a, centre)).norm() <= keep) near_arcs_.push_back(&a);
  }
}

bool VisionHealth::fartherThan(const geometry::Vec2& p, double reach) const {
  // FieldModel::closestPoint's minimum, over the shortlist: a line left out is further anyway.
  // A line within reach settles it (the minimum is no larger, sqrt does not decrease): most
  // points lie on a line, the others' distances need not be taken.
  double best_squared = std::numeric_limits<double>::infinity();
  for (const field::LineSegment* s : near_segments_) {
    const double d2 = (p - field::closestPointOnSegment(*s, p)).squaredNorm();
    if (std::sqrt(d2) <= reach) return false;
    best_squared = std::min(best_squared, d2);
  }
  for (const field::LineArc* a : near_arcs_) {
    const double d2 = (p - field::closestPointOnArc(*a, p)).squaredNorm();
    if (std::sqrt(d2) <= reach) return false;
    best_squared = std::min(best_squared, d2);
  }
  return std::sqrt(best_squared) > reach;
}

VisionHealth::FieldFacts VisionHealth::fieldFacts(const VisionResult& result, const FramePose& at) {
  FieldFacts f;
  f.posed = true;
  const PoseTransform pose(at.pose);
  const double range = params_.field_range_m;
  const double off_line = params_.off_line_m + at.sigma_m;
  selectNearbyLines(at.pose.position(), range, off_line);
  // The lines' outer edges, plus the same margin.
  for (const perception::LinePoint& q : result.lines.points) {
    const geometry::Vec2 robot(q.x, q.y);
    if (!robot.allFinite() || robot.norm() > range) continue;
    const geometry::Vec2 p = pose.toField(robot);
    ++f.points;
    if (!field_->insideLines(p, off_line)) ++f.off_field;
    if (fartherThan(p, off_line)) ++f.off_line;
  }
  // Floor samples that see the hall floor beyond the carpet (clear of it by the margin), of
  // those within range.
  const geometry::Vec2 carpet = field_->carpetHalfExtent();
  for (const InRangeSample& s : in_range_samples_) {
    const geometry::Vec2 p = pose.toField(geometry::Vec2(s.x, s.y));
    if (std::abs(p.x()) < carpet.x() + off_line && std::abs(p.y()) < carpet.y() + off_line) {
      continue;
    }
    ++f.beyond;
    if (sample_classes_[s.index] == camera::ColourClass::kGreen) ++f.green_beyond;
  }
  lineCoverageFacts(result, at.pose, f);
  return f;
}

bool VisionHealth::usefullyInView(const geometry::Vec2& robot, double min_radius) const {
  const camera::MirrorParams& m = mirror_.params();
  // A round mirror: the image radius of a floor point depends on its distance alone (the pixel's
  // direction needs atan2, cos and sin). Where that radius and the pixel's radius (the same
  // within 1e-13 px: a unit vector times r, added to and taken from the centre) are clear of every
  // limit below by far more, and the whole circle of that radius lies inside the image, the answer
  // is known without the pixel; anywhere else the pixel is computed as before.
  if (!m.distance.isTable()) {
    const geometry::Vec2 axis = mirror_.robotToAxis(robot);
    const double r = m.distance.imageRadius(axis.norm(), 0.0);  // the bearing is not used
    if (!std::isfinite(r) || r < m.self_radius || r > m.outer_radius) return false;
    constexpr double kClear = 1e-6;
    const double limit = std::min({m.outer_radius, m.useful_radius, m.distance.maxRadius()});
    if (r < min_radius - kClear || r > limit + kClear) return false;
    const double reach = r + kClear;
    if (r > min_radius + kClear && r < limit - kClear && m.centre.x() - reach >= -0.5 &&
        m.centre.y() - reach >= -0.5 && m.centre.x() + reach < m.width - 0.5 &&
        m.centre.y() + reach < m.height - 0.5) {
      return true;
    }
  }
  const auto pixel = mirror_.robotToImage(robot);
  return pixel && mirror_.zone(*pixel) == camera::MirrorZone::kUseful &&
         !(mirror_.radiusOf(*pixel) < min_radius);
}

bool VisionHealth::nearPoint(int bx, int by) const {
  const int side = 2 * bin_half_ + 1;
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      const int x = bx + dx, y = by + dy;
      if (x < -bin_half_ || x > bin_half_ || y < -bin_half_ || y > bin_half_) continue;
      if (bins_[static_cast<std::size_t>((y + bin_half_) * side + x + bin_half_)] != 0) {
        return true;
      }
    }
  }
  return false;
}

void VisionHealth::lineCoverageFacts(const VisionResult& result, const geometry::Pose2& at,
                                     FieldFacts& f) {
  // The model's line in view (within range, where the mirror sees the floor usefully) and the
  // part of it with a line point nearby. Points are binned on a grid of the coverage distance.
  const double range = params_.field_range_m;
  const double cell = params_.coverage_distance_m;
  for (const std::size_t b : bins_set_)
    bins_[b] = 0;
  bins_set_.clear();
  const int side = 2 * bin_half_ + 1;
  const double half = bin_half_;
  for (const perception::LinePoint& q : result.lines.points) {
    if (!(std::isfinite(q.x) && std::isfinite(q.y))) continue;
    const double bx = std::floor(q.x / cell), by = std::floor(q.y / cell);
    // Beyond the grid: no sample within range has it beside its own bin.
    if (bx < -half || bx > half || by < -half || by > half) continue;
    const auto b = static_cast<std::size_t>((static_cast<int>(by) + bin_half_) * side +
                                            static_cast<int>(bx) + bin_half_);
    if (bins_[b] == 0) {
      bins_[b] = 1;
      bins_set_.push_back(b);
    }
  }
  if (line_buckets_.empty()) return;
  const PoseTransform pose(at);
  const double self = mirror_.params().self_radius;
  // Only the squares within range of the position (1 cm more for rounding): a sample in any
  // other is further than range from the robot, the test below would skip it. The sums add the
  // same step for each sample counted: the order the samples come in does not change them.
  const double reach = range + 0.01;
  const auto index = [&](double coordinate, double origin, int count) {
    return static_cast<int>(
        std::clamp(std::floor((coordinate - origin) / line_bucket_m_), -1.0, double(count)));
  };
  const geometry::Vec2 centre = at.position();
  const int c0 = std::max(0, index(centre.x() - reach, line_origin_.x(), line_columns_));
  const int c1 =
      std::min(line_columns_ - 1, index(centre.x() + reach, line_origin_.x(), line_columns_));
  const int r0 = std::max(0, index(centre.y() - reach, line_origin_.y(), line_rows_));
  const int r1 = std::min(line_rows_ - 1, index(centre.y() + reach, line_origin_.y(), line_rows_));
  for (int row = r0; row <= r1; ++row) {
    for (int column = c0; column <= c1; ++column) {
      const auto [begin, end] =
          line_buckets_[static_cast<std::size_t>(row) * static_cast<std::size_t>(line_columns_) +
                        static_cast<std::size_t>(column)];
      for (std::size_t k = begin; k < end; ++k) {
        const geometry::Vec2 robot = pose.toRobot(line_samples_[k]);
        if (robot.norm() > range || !usefullyInView(robot, self + 4.0)) continue;
        f.in_view_m += line_sample_m_;
        if (nearPoint(static_cast<int>(std::floor(robot.x() / cell)),
                      static_cast<int>(std::floor(robot.y() / cell)))) {
          f.covered_m += line_sample_m_;
        }
      }
    }
  }
}

VisionHealth::FieldFacts VisionHealth::fieldSum() const {
  FieldFacts sum;
  for (std::size_t i = 0; i < field_filled_; ++i) {
    const FieldFacts& f = field_window_[i];
    if (!f.posed) continue;
    sum.posed = true;
    sum.points += f.points;
    sum.off_line += f.off_line;
    sum.off_field += f.off_field;
    sum.beyond += f.beyond;
    sum.green_beyond += f.green_beyond;
    sum.in_view_m += f.in_view_m;
    sum.covered_m += f.covered_m;
  }
  return sum;
}

int VisionHealth::posedLineFrames() const {
  int n = 0;
  for (std::size_t i = 0; i < field_filled_; ++i)
    n += field_window_[i].posed ? 1 : 0;
  return n;
}

double VisionHealth::offLineShare() const {
  const FieldFacts& f = field_sum_;
  return f.points >= params_.min_field_points ? static_cast<double>(f.off_line) / f.points : -1.0;
}

double VisionHealth::offFieldShare() const {
  const FieldFacts& f = field_sum_;
  return f.points >= params_.min_field_points ? static_cast<double>(f.off_field) / f.points : -1.0;
}

double VisionHealth::greenBeyondShare() const {
  const FieldFacts& f = field_sum_;
  return f.beyond >= params_.min_beyond_samples ? static_cast<double>(f.green_beyond) / f.beyond
                                                : -1.0;
}

double VisionHealth::lineCoverage() const {
  const FieldFacts& f = field_sum_;
  return f.in_view_m >= params_.min_line_in_view_m ? f.covered_m / f.in_view_m : -1.0;
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

void VisionHealth::classifySamples(const camera::FrameView& frame, int& green, int& orange,
                                   int& counted) {
  const ClassLookup* lookup = frame.format == camera::PixelFormat::kYuyv ? lookup_ : nullptr;
  for (std::size_t i = 0; i < samples_.size(); ++i) {
    const SamplePixel& s = samples_[i];
    sample_classes_[i] = camera::ColourClass::kUnknown;
    if (!frame.contains(s.u, s.v)) continue;
    camera::ColourClass c;
    if (lookup) {
      // ColourTable::classifyPixel's YUYV case, with the lookup's classes.
      const std::uint8_t* pair = frame.data + static_cast<std::ptrdiff_t>(s.v) * frame.stride +
                                 static_cast<std::ptrdiff_t>(s.u >> 1) * 4;
      c = lookup->classifyYuv(pair[(s.u & 1) * 2], pair[1], pair[3]);
    } else {
      c = table_.classifyPixel(frame, s.u, s.v);
    }
    sample_classes_[i] = c;
    green += c == camera::ColourClass::kGreen ? 1 : 0;
    orange += c == camera::ColourClass::kOrange ? 1 : 0;
    ++counted;
  }
}

void VisionHealth::update(const camera::FrameView& frame, const VisionResult& result,
                          const std::optional<FramePose>& pose) {
  int green = 0, orange = 0, counted = 0;
  classifySamples(frame, green, orange, counted);
  FrameFacts& facts = window_[next_];
  facts.green = counted > 0 ? static_cast<float>(green) / static_cast<float>(counted) : 0.0f;
  facts.orange = counted > 0 ? static_cast<float>(orange) / static_cast<float>(counted) : 0.0f;
  // A periodic re-initialisation is a planned search, not a sign of trouble.
  facts.searched = result.tracking.initial_searches > 0 && !result.tracking.reinitialised;
  next_ = (next_ + 1) % window_.size();
  filled_ = std::min(filled_ + 1, window_.size());
  if (result.lines_detected) {
    line_frames_without_points_ = result.lines.points.empty() ? line_frames_without_points_ + 1 : 0;
    const bool usable = field_ && pose && geometry::isFinite(pose->pose) &&
                        std::isfinite(pose->sigma_m) && pose->sigma_m <= params_.max_pose_sigma_m;
    field_window_[field_next_] = usable ? fieldFacts(result, *pose) : FieldFacts{};
    field_next_ = (field_next_ + 1) % field_window_.size();
    field_filled_ = std::min(field_filled_ + 1, field_window_.size());
    field_sum_ = fieldSum();
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
  // The field checks, where there are enough facts (a negative share: not enough).
  if (const double off = offLineShare(); off > params_.max_off_line_share) {
    add(
        fmt::format("{:.0f} % of the line points on no line of the field at fusion's pose "
                    "(> {:.0f} %)",
                    100.0 * off, 100.0 * params_.max_off_line_share));
  }
  if (const double off = offFieldShare(); off > params_.max_off_field_share) {
    add(fmt::format("{:.0f} % of the line points off the field at fusion's pose (> {:.0f} %)",
                    100.0 * off, 100.0 * params_.max_off_field_share));
  }
  if (const double beyond = greenBeyondShare(); beyond > params_.max_green_beyond_share) {
    add(
        fmt::format("field colour beyond the field: {:.0f} % of the floor beyond the carpet "
                    "(> {:.0f} %)",
                    100.0 * beyond, 100.0 * params_.max_green_beyond_share));
  }
  if (const double coverage = lineCoverage();
      coverage >= 0.0 && coverage < params_.min_line_coverage) {
    const FieldFacts& f = field_sum_;
    add(
        fmt::format("line points along {:.0f} % of the {:.0f} m of line the field puts in view "
                    "(< {:.0f} %)",
                    100.0 * coverage, f.in_view_m / std::max(1, posedLineFrames()),
                    100.0 * params_.min_line_coverage));
  }
  // Judged on a full window only: the first frame always searches.
  const double searches = searchFraction();
  if (filled_ == window_.size() && searches > params_.max_search_fraction) {
    add(fmt::format("re-seeding green in {:.0f} % of frames", 100.0 * searches));
  }
}

}  // namespace fieldline::region_tracking
