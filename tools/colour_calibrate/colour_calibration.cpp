#include "tools/colour_calibrate/colour_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "tools/calibration_common/percentile.hpp"

namespace fieldline::calibration {
namespace {

using camera::ColourClass;
using camera::Yuv;
using camera::YuvBox;
using geometry::Vec2;

double elementWidth(const field::FieldModel& field, const field::FieldModel::Closest& c) {
  if (c.element < 0) return field.lineWidth();
  return c.is_arc ? field.arcs()[static_cast<std::size_t>(c.element)].width
                  : field.segments()[static_cast<std::size_t>(c.element)].width;
}

// Value at percentile p (0..100) of sorted values; 0 when there are none.
int percentile(const std::vector<std::uint8_t>& sorted, double p) {
  return sorted.empty() ? 0 : percentileOfSorted(sorted, p);
}

std::array<std::uint8_t, 2> range(int lo, int hi, int margin) {
  return {static_cast<std::uint8_t>(std::clamp(lo - margin, 0, 255)),
          static_cast<std::uint8_t>(std::clamp(hi + margin, 0, 255))};
}

// A robust box around samples: per channel [low, high] percentiles widened by the margin.
YuvBox robustBox(ColourClass colour, const std::vector<Yuv>& samples, double low, double high,
                 int margin) {
  std::array<std::vector<std::uint8_t>, 3> ch;
  for (auto& c : ch)
    c.reserve(samples.size());
  for (const Yuv& s : samples) {
    ch[0].push_back(s.y);
    ch[1].push_back(s.u);
    ch[2].push_back(s.v);
  }
  for (auto& c : ch)
    std::sort(c.begin(), c.end());
  YuvBox box;
  box.colour = colour;
  box.y = range(percentile(ch[0], low), percentile(ch[0], high), margin);
  box.u = range(percentile(ch[1], low), percentile(ch[1], high), margin);
  box.v = range(percentile(ch[2], low), percentile(ch[2], high), margin);
  return box;
}

// Boxes that hold a surface's colours under every light of the fit. A gain g on R, G and B
// scales luma and the chroma's distance from grey alike, so (U - 128) / Y and (V - 128) / Y do
// not change with the light: their robust ranges, the luma's robust range times the light range,
// and per luma band (geometric) the chroma those ratios give there, widened by margin_levels
// (noise). `to_white`: the luma range runs up to 255 (white saturates in bright light).
std::vector<YuvBox> coneBoxes(ColourClass colour, const std::vector<Yuv>& samples,
                              const FitParams& params, double low, double high, int bands,
                              bool to_white) {
  const double glo = params.light_range[0], ghi = params.light_range[1];
  if (!(glo > 0.0 && glo <= 1.0 && ghi >= 1.0)) {
    throw std::invalid_argument("colour calibration: light_range must be 0 < low <= 1 <= high");
  }
  // Ratios from the brighter half of the samples: in dark pixels the sensor noise, which does
  // not scale with the light, dominates the ratio (margin_levels covers the noise).
  const int medianY = percentileOfLuma(samples, 50.0);
  std::vector<double> cu, cv;
  for (const Yuv& s : samples) {
    if (s.y < medianY || s.y < 8) continue;
    cu.push_back((s.u - 128.0) / s.y);
    cv.push_back((s.v - 128.0) / s.y);
  }
  if (cu.empty()) throw std::runtime_error("colour calibration: no usable samples");
  const double cuLo = percentileOf(cu, low), cuHi = percentileOf(cu, high);
  const double cvLo = percentileOf(cv, low), cvHi = percentileOf(cv, high);
  const int chromaMargin = params.margin_levels;
  const double yLo = std::max(1.0, percentileOfLuma(samples, low) * glo - params.margin_levels);
  const double yHi =
      to_white ? 255.0
               : std::min(255.0, percentileOfLuma(samples, high) * ghi + params.margin_levels);
  std::vector<YuvBox> boxes;
  const int n = std::max(1, bands);
  for (int b = 0; b < n; ++b) {
    const double y0 = yLo * std::pow(yHi / yLo, static_cast<double>(b) / n);
    const double y1 = yLo * std::pow(yHi / yLo, static_cast<double>(b + 1) / n);
    auto chroma = [&](double rlo, double rhi) {
      const double lo = std::min(rlo * y0, rlo * y1);
      const double hi = std::max(rhi * y0, rhi * y1);
      return range(static_cast<int>(std::floor(128.0 + lo)),
                   static_cast<int>(std::ceil(128.0 + hi)), chromaMargin);
    };
    YuvBox box;
    box.colour = colour;
    box.y = {static_cast<std::uint8_t>(std::clamp(static_cast<int>(std::floor(y0)), 0, 255)),
             static_cast<std::uint8_t>(std::clamp(static_cast<int>(std::ceil(y1)), 0, 255))};
    box.u = chroma(cuLo, cuHi);
    box.v = chroma(cvLo, cvHi);
    boxes.push_back(box);
  }
  return boxes;
}

void checkSize(const camera::MirrorModel& mirror, const camera::FrameView& f) {
  if (!f.valid() || f.width != mirror.width() || f.height != mirror.height()) {
    throw std::invalid_argument(
        fmt::format("colour calibration: frame is {}x{}, the camera model expects {}x{}", f.width,
                    f.height, mirror.width(), mirror.height()));
  }
}

// Unit normal of the closest line element at p (field frame).
Vec2 lineNormal(const field::FieldModel& field, const field::FieldModel::Closest& c,
                const Vec2& p) {
  if (c.distance > 1e-4) return (p - c.point) / c.distance;
  if (c.element < 0) return Vec2::UnitX();
  if (c.is_arc) {
    const Vec2 d = p - field.arcs()[static_cast<std::size_t>(c.element)].centre;
    return d.norm() > 1e-9 ? Vec2(d.normalized()) : Vec2(Vec2::UnitX());
  }
  const field::LineSegment& s = field.segments()[static_cast<std::size_t>(c.element)];
  const Vec2 t = (s.b - s.a).normalized();
  return {-t.y(), t.x()};
}

}  // namespace

std::vector<PredictedPixel> predictPixels(const camera::MirrorModel& mirror,
                                          const field::FieldModel& field,
                                          const geometry::Pose2& pose, const MaskParams& params) {
  const int w = mirror.width();
  const int h = mirror.height();
  std::vector<PredictedPixel> out(static_cast<std::size_t>(w) * h);
  const Vec2 carpet = field.carpetHalfExtent();
  const double halfLength = field.length() / 2.0;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Vec2 pixel(u, v);
      if (mirror.zone(pixel) != camera::MirrorZone::kUseful) continue;
      const std::optional<Vec2> floor = mirror.imageToRobot(pixel);
      if (!floor) continue;
      const Vec2 mpp = mirror.metresPerPixel(pixel);
      if (!mpp.allFinite()) continue;
      const Vec2 p = geometry::pointRobotToField(pose, *floor);
      const field::FieldModel::Closest closest = field.closestPoint(p);
      const double half = elementWidth(field, closest) / 2.0;
      // Floor length one pixel spans across the line (along its normal): the radial and
      // tangential footprints weighted by the normal's direction in the robot frame.
      const Vec2 normalField = lineNormal(field, closest, p);
      const Vec2 normal = geometry::vectorFieldToRobot(pose, normalField);
      const Vec2 radial = floor->normalized();
      const double cr = normal.dot(radial) / mpp.x();
      const double ct = (normal.x() * -radial.y() + normal.y() * radial.x()) / mpp.y();
      const double footprint = 1.0 / std::max(1e-9, std::sqrt(cr * cr + ct * ct));
      PredictedPixel& px = out[static_cast<std::size_t>(v) * w + u];
      const bool onCarpet = std::abs(p.x()) <= carpet.x() && std::abs(p.y()) <= carpet.y();
      if (closest.distance <= half) {
        px.truth = Expected::kLine;
      } else if (onCarpet) {
        px.truth = Expected::kCarpet;
      } else {
        px.truth = Expected::kOffCarpet;
      }
      const double range = floor->norm();
      const double markDistance = [&] {
        double d = std::numeric_limits<double>::infinity();
        for (const Vec2& m : field.penaltyMarks())
          d = std::min(d, (p - m).norm());
        return d;
      }();
      px.line_core = px.truth == Expected::kLine && range <= params.max_line_distance &&
                     closest.distance <= half - params.line_margin_px * footprint;
      const double carpetMargin =
          params.carpet_margin_px * std::max(mpp.x(), mpp.y()) + params.carpet_margin_m;
      px.carpet_core = px.truth == Expected::kCarpet && range <= params.max_carpet_distance &&
                       closest.distance >= half + carpetMargin &&
                       std::abs(p.x()) <= halfLength - carpetMargin &&
                       std::abs(p.y()) <= carpet.y() - carpetMargin &&
                       markDistance > params.mark_radius + carpetMargin;
    }
  }
  return out;
}

namespace {

// Pixels within `margin` px of a pixel painted in any user mask over `frame` (the same image).
std::vector<std::uint8_t> paintedNear(const camera::MirrorModel& mirror,
                                      const camera::FrameView& frame,
                                      const std::vector<UserMask>& masks, int margin = 3) {
  const int w = mirror.width(), h = mirror.height();
  std::vector<std::uint8_t> out(static_cast<std::size_t>(w) * h, 0);
  for (const UserMask& m : masks) {
    if (m.frame.data != frame.data || m.mask.size() != out.size()) continue;
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        if (!m.mask[static_cast<std::size_t>(v) * w + u]) continue;
        for (int dv = std::max(-margin, -v); dv <= margin && v + dv < h; ++dv) {
          for (int du = std::max(-margin, -u); du <= margin && u + du < w; ++du) {
            out[static_cast<std::size_t>(v + dv) * w + u + du] = 1;
          }
        }
      }
    }
  }
  return out;
}

// The carpet's and the lines' pixels as the poses predict them, without what the user painted.
void collectSamples(const camera::MirrorModel& mirror, const field::FieldModel& field,
                    const std::vector<PosedFrame>& frames, const std::vector<UserMask>& masks,
                    const FitParams& params, std::vector<Yuv>& green,
                    std::vector<Yuv>& lineSamples) {
  for (const PosedFrame& f : frames) {
    checkSize(mirror, f.frame);
    const std::vector<PredictedPixel> predicted =
        predictPixels(mirror, field, f.pose, params.masks);
    const std::vector<std::uint8_t> painted = paintedNear(mirror, f.frame, masks);
    for (int v = 0; v < mirror.height(); ++v) {
      for (int u = 0; u < mirror.width(); ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * mirror.width() + u;
        // What the user painted as ball or obstacle is neither carpet nor line.
        if (painted[i]) continue;
        const PredictedPixel& px = predicted[i];
        if (px.carpet_core) green.push_back(camera::readYuv(f.frame, u, v));
        if (px.line_core) lineSamples.push_back(camera::readYuv(f.frame, u, v));
      }
    }
  }
}

// The carpet's median per channel.
std::array<double, 3> medianOf(const std::vector<Yuv>& green) {
  std::array<double, 3> median{};
  std::array<std::vector<std::uint8_t>, 3> channels;
  for (const Yuv& g : green) {
    channels[0].push_back(g.y);
    channels[1].push_back(g.u);
    channels[2].push_back(g.v);
  }
  for (std::size_t k = 0; k < 3; ++k) {
    auto mid = channels[k].begin() + static_cast<std::ptrdiff_t>(channels[k].size() / 2);
    std::nth_element(channels[k].begin(), mid, channels[k].end());
    median[k] = *mid;
  }
  return median;
}

// Classes painted by the user: a box each, added to the class's fit.
void addPaintedClasses(const camera::MirrorModel& mirror, const std::vector<UserMask>& masks,
                       const FitParams& params, Calibration& result) {
  for (const UserMask& m : masks) {
    // Painted as "not carpet, no class": only kept out of the samples above.
    if (m.colour == ColourClass::kUnknown) continue;
    checkSize(mirror, m.frame);
    if (m.mask.size() != static_cast<std::size_t>(mirror.width()) * mirror.height()) {
      throw std::invalid_argument("colour calibration: a mask of another size than its frame");
    }
    std::vector<Yuv> samples;
    for (int v = 0; v < mirror.height(); ++v) {
      for (int u = 0; u < mirror.width(); ++u) {
        if (m.mask[static_cast<std::size_t>(v) * mirror.width() + u] != 0) {
          samples.push_back(camera::readYuv(m.frame, u, v));
        }
      }
    }
    if (samples.size() < 10) {
      throw std::runtime_error(fmt::format("colour calibration: the {} mask paints only {} pixels",
                                           camera::colourName(m.colour), samples.size()));
    }
    auto fit = std::find_if(result.fits.begin(), result.fits.end(),
                            [&](const ClassFit& f) { return f.colour == m.colour; });
    const YuvBox box = robustBox(m.colour, samples, params.low_percentile, params.high_percentile,
                                 params.margin_levels);
    if (fit == result.fits.end()) {
      result.fits.push_back({m.colour, {box}, static_cast<int>(samples.size())});
    } else {
      fit->boxes.push_back(box);
      fit->samples += static_cast<int>(samples.size());
    }
  }
}

}  // namespace

Calibration calibrate(const camera::MirrorModel& mirror, const field::FieldModel& field,
                      const std::vector<PosedFrame>& frames, const std::vector<UserMask>& masks,
                      const std::vector<YuvBox>& base, const FitParams& params) {
  if (frames.empty()) throw std::invalid_argument("colour calibration: no frames");
  std::vector<Yuv> green, lineSamples;
  collectSamples(mirror, field, frames, masks, params, green, lineSamples);
  if (static_cast<int>(green.size()) < params.min_samples) {
    throw std::runtime_error(fmt::format(
        "colour calibration: only {} carpet pixels predicted (need {}): is the pose right and "
        "the carpet in view?",
        green.size(), params.min_samples));
  }

  Calibration result;
  result.carpet_median = medianOf(green);
  ClassFit greenFit{ColourClass::kGreen,
                    coneBoxes(ColourClass::kGreen, green, params, params.green_low_percentile,
                              params.green_high_percentile, params.green_bands, false),
                    static_cast<int>(green.size())};

  // White: the line pixels without the darker mixed pixels at the paint's blurred edges (below
  // 80 % of the median luma).
  std::vector<Yuv> white = lineSamples;
  if (!white.empty()) {
    const int median = percentileOfLuma(white, 50.0);
    std::erase_if(white, [&](const Yuv& s) { return s.y < 0.8 * median; });
  }
  if (static_cast<int>(white.size()) < params.min_line_samples) {
    throw std::runtime_error(fmt::format(
        "colour calibration: only {} of {} predicted line pixels are bright enough (need {}): "
        "is a line within {} m in view?",
        white.size(), lineSamples.size(), params.min_line_samples, params.masks.max_line_distance));
  }
  ClassFit whiteFit{ColourClass::kWhite,
                    coneBoxes(ColourClass::kWhite, white, params, params.white_low_percentile,
                              params.high_percentile, params.white_bands, true),
                    static_cast<int>(white.size())};

  // Green first: where the cones overlap (dim washed-out carpet, bright low-contrast paint) the
  // many carpet pixels stay green; a few line pixels turning green cost less than carpet turning
  // white, which breaks the green regions and puts false lines into them.
  result.fits.push_back(greenFit);
  result.fits.push_back(whiteFit);

  // Classes painted by the user.
  addPaintedClasses(mirror, masks, params, result);

  for (const ClassFit& f : result.fits) {
    result.boxes.insert(result.boxes.end(), f.boxes.begin(), f.boxes.end());
  }
  for (const YuvBox& b : base) {
    const bool fitted = std::any_of(result.fits.begin(), result.fits.end(),
                                    [&](const ClassFit& f) { return f.colour == b.colour; });
    if (!fitted) result.boxes.push_back(b);
  }
  return result;
}

int percentileOfLuma(const std::vector<Yuv>& samples, double p) {
  std::vector<std::uint8_t> y;
  y.reserve(samples.size());
  for (const Yuv& s : samples)
    y.push_back(s.y);
  std::sort(y.begin(), y.end());
  return percentile(y, p);
}

Coverage measureCoverage(const camera::MirrorModel& mirror, const field::FieldModel& field,
                         const std::vector<PosedFrame>& frames, const camera::ColourTable& table,
                         const MaskParams& params) {
  Coverage c;
  long carpet_green = 0, carpet_white = 0, line_white = 0, line_green = 0, offGreen = 0;
  for (const PosedFrame& f : frames) {
    checkSize(mirror, f.frame);
    const std::vector<PredictedPixel> predicted = predictPixels(mirror, field, f.pose, params);
    for (int v = 0; v < mirror.height(); ++v) {
      for (int u = 0; u < mirror.width(); ++u) {
        const PredictedPixel& px = predicted[static_cast<std::size_t>(v) * mirror.width() + u];
        if (px.truth == Expected::kNone) continue;
        const ColourClass k = table.classifyPixel(f.frame, u, v);
        const bool isGreen = k == ColourClass::kGreen;
        const bool isWhite = k == ColourClass::kWhite;
        if (px.truth == Expected::kCarpet) {
          ++c.carpet_pixels;
          carpet_green += isGreen;
          carpet_white += isWhite;
        } else if (px.truth == Expected::kLine) {
          const std::optional<Vec2> floor = mirror.imageToRobot(Vec2(u, v));
          if (!floor || floor->norm() > params.max_line_distance) continue;
          ++c.line_pixels;
          line_white += isWhite;
          line_green += isGreen;
        } else {
          ++c.off_carpet_pixels;
          offGreen += isGreen;
        }
      }
    }
  }
  auto share = [](long n, long of) { return of > 0 ? static_cast<double>(n) / of : 0.0; };
  c.carpet_green = share(carpet_green, c.carpet_pixels);
  c.carpet_white = share(carpet_white, c.carpet_pixels);
  c.line_white = share(line_white, c.line_pixels);
  c.line_green = share(line_green, c.line_pixels);
  c.off_carpet_green = share(offGreen, c.off_carpet_pixels);
  return c;
}

std::string colourTableYaml(const std::vector<YuvBox>& boxes, const std::string& comment) {
  std::string out;
  std::string line;
  for (const char ch : comment + "\n") {
    if (ch == '\n') {
      out += "# " + line + "\n";
      line.clear();
    } else {
      line += ch;
    }
  }
  out += "colours:\n";
  // Grouped by class in the order of first appearance; within a class in table order. A class's
  // boxes are one map entry, so classes must not interleave: the order of first appearance is
  // kept, which is the calibrated classes first.
  std::vector<ColourClass> order;
  for (const YuvBox& b : boxes) {
    if (std::find(order.begin(), order.end(), b.colour) == order.end()) order.push_back(b.colour);
  }
  for (const ColourClass k : order) {
    out += fmt::format("  {}:\n", camera::colourName(k));
    for (const YuvBox& b : boxes) {
      if (b.colour != k) continue;
      out += fmt::format("    - {{y: [{}, {}], u: [{}, {}], v: [{}, {}]}}\n", b.y[0], b.y[1],
                         b.u[0], b.u[1], b.v[0], b.v[1]);
    }
  }
  return out;
}

LineScore scoreLinePoints(const camera::MirrorModel& mirror, const field::FieldModel& field,
                          const geometry::Pose2& pose, const perception::LinePoints& lines,
                          const ScoreParams& params) {
  LineScore score;
  const int w = mirror.width();
  const int h = mirror.height();
  // Which pixels the model says are line (any part of the pixel's floor point on the paint).
  std::vector<std::uint8_t> isLine(static_cast<std::size_t>(w) * h, 0);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const camera::MirrorZone zone = mirror.zone(Vec2(u, v));
      if (zone != camera::MirrorZone::kUseful && zone != camera::MirrorZone::kFar) continue;
      const std::optional<Vec2> floor = mirror.imageToRobot(Vec2(u, v));
      if (!floor) continue;
      const field::FieldModel::Closest c =
          field.closestPoint(geometry::pointRobotToField(pose, *floor));
      isLine[static_cast<std::size_t>(v) * w + u] = c.distance <= elementWidth(field, c) / 2.0;
    }
  }
  const int reach = static_cast<int>(std::ceil(params.tolerance_px));
  const double tol2 = params.tolerance_px * params.tolerance_px;
  for (const perception::LinePoint& p : lines.points) {
    ++score.points;
    const int cu = static_cast<int>(std::lround(p.u));
    const int cv = static_cast<int>(std::lround(p.v));
    bool near = false;
    for (int dv = -reach; dv <= reach && !near; ++dv) {
      for (int du = -reach; du <= reach && !near; ++du) {
        const int u = cu + du, v = cv + dv;
        if (u < 0 || v < 0 || u >= w || v >= h) continue;
        const double dx = u - p.u, dy = v - p.v;
        near = dx * dx + dy * dy <= tol2 && isLine[static_cast<std::size_t>(v) * w + u] != 0;
      }
    }
    score.precise += near ? 1 : 0;
  }
  score.precision = score.points > 0 ? static_cast<double>(score.precise) / score.points : 0.0;

  // Recall: model line samples within max_distance whose pixel is in the useful zone.
  const double selfClear = mirror.params().self_radius + 8.0;
  for (const Vec2& s : field.sampleLines(params.sample_step)) {
    const Vec2 r = geometry::pointFieldToRobot(pose, s);
    if (r.norm() > params.max_distance) continue;
    const std::optional<Vec2> px = mirror.robotToImage(r);
    if (!px || mirror.zone(*px) != camera::MirrorZone::kUseful) continue;
    if (mirror.radiusOf(*px) < selfClear) continue;
    score.visible_length += params.sample_step;
    bool covered = false;
    for (const auto& [from, to] : lines.sequences) {
      for (int i = from; i < to && !covered; ++i) {
        const perception::LinePoint& a = lines.points[static_cast<std::size_t>(i)];
        const perception::LinePoint& b =
            lines.points[static_cast<std::size_t>(i + 1 < to ? i + 1 : i)];
        const Vec2 pa(a.u, a.v), pb(b.u, b.v);
        const Vec2 ab = pb - pa;
        const double len2 = ab.squaredNorm();
        const double t = len2 > 0 ? std::clamp((*px - pa).dot(ab) / len2, 0.0, 1.0) : 0.0;
        covered = (pa + t * ab - *px).squaredNorm() <= tol2;
      }
      if (covered) break;
    }
    if (covered) score.covered_length += params.sample_step;
  }
  score.recall = score.visible_length > 0 ? score.covered_length / score.visible_length : 0.0;
  return score;
}

}  // namespace fieldline::calibration
