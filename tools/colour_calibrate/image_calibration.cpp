#include "tools/colour_calibrate/image_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include <fmt/core.h>

#include "services/fusion/line_matcher.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/calibration_common/floor_colour.hpp"
#include "tools/calibration_common/grey_image.hpp"
#include "tools/calibration_common/percentile.hpp"
#include "tools/calibration_common/ridges.hpp"
#include "tools/calibration_common/staged_output.hpp"

#include "tools/colour_calibrate/image_stages.hpp"

namespace fieldline::calibration {
namespace imagefit {

double chromaDistance(const Yuv& c, double u, double v) {
  return std::hypot(c.u - u, c.v - v);
}

Cone coneOf(const std::vector<Yuv>& s, double wu, double wv, const std::array<double, 2>& light,
            double min_radius, double low_pct, double high_pct) {
  std::vector<double> ys, qu, qv;
  for (const Yuv& c : s)
    ys.push_back(c.y);
  const double ymed = percentileOf(ys, 50.0);
  for (const Yuv& c : s) {
    if (c.y < ymed || c.y < 8) continue;  // the brighter half: noise dominates dark ratios
    qu.push_back((c.u - wu) / c.y);
    qv.push_back((c.v - wv) / c.y);
  }
  Cone cone;
  cone.ru = percentileOf(qu, 50.0);
  cone.rv = percentileOf(qv, 50.0);
  cone.ref_y = ymed;
  std::vector<double> dist;
  for (const Yuv& c : s) {
    dist.push_back(std::hypot(c.u - (wu + cone.ru * c.y), c.v - (wv + cone.rv * c.y)) /
                   std::max(1.0, c.y / ymed));
  }
  // + 2: a cell of the lookup table spans 4 levels.
  cone.radius = std::max(min_radius, percentileOf(dist, 99.0) + 2.0);
  cone.y_lo = std::max(0.0, percentileOf(ys, low_pct) * light[0] - 2.0);
  cone.y_hi = std::min(255.0, percentileOf(ys, high_pct) * light[1] + 2.0);
  return cone;
}

PixelGeometry geometryOf(const camera::MirrorModel& mirror) {
  const int w = mirror.width(), h = mirror.height();
  PixelGeometry g;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  g.distance.assign(n, std::numeric_limits<double>::quiet_NaN());
  g.robot.assign(n, Vec2::Zero());
  g.mpp_min.assign(n, 0.0);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      if (mirror.zone(Vec2(u, v)) != camera::MirrorZone::kUseful) continue;
      const std::optional<Vec2> r = mirror.imageToRobot(Vec2(u, v));
      if (!r) continue;
      g.distance[i] = r->norm();
      g.robot[i] = *r;
      const Vec2 m = mirror.metresPerPixel(Vec2(u, v));
      g.mpp_min[i] = std::min(m.x(), m.y());
    }
  }
  return g;
}

}  // namespace imagefit

namespace {

using camera::ColourClass;
using camera::Vec2;
using camera::Yuv;

}  // namespace

namespace imagefit {

FromImages::FromImages(const camera::MirrorModel& mirror_in, const field::FieldModel& field_in,
                       const std::vector<camera::FrameView>& frames_in,
                       const std::vector<std::optional<geometry::Pose2>>& poses_in,
                       const ImageFitParams& params_in)
    : mirror(mirror_in),
      field(field_in),
      frames(frames_in),
      poses(poses_in),
      params(params_in),
      w(mirror_in.width()),
      h(mirror_in.height()),
      n(static_cast<std::size_t>(w) * h),
      geo(geometryOf(mirror_in)) {
  for (const camera::FrameView& f : frames)
    planes.push_back(yuvPlane(f));
}

void FromImages::findFloor() {
  std::vector<std::uint8_t> annulus(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    annulus[i] = geo.distance[i] >= params.floor_from_m && geo.distance[i] <= params.floor_to_m;
  }
  floor_colour = findFloorColour(planes, annulus, 2);
  if (floor_colour.pixels < 200) {
    throw Refusal(
        fmt::format("the camera model shows almost no floor between {} and {} m: check --camera",
                    params.floor_from_m, params.floor_to_m));
  }
  out.floor.chroma_sigma = floor_colour.chroma_sigma;
  out.floor.share = floor_colour.share;
  if (out.floor.share < params.min_floor_share) {
    throw Refusal(fmt::format(
        "no dominant floor colour around the robot: the commonest colour (U {:.0f}, V {:.0f}, "
        "luma {:.0f}-{:.0f}) holds {:.0f} % of the pixels between {} and {} m (at least {:.0f} % "
        "expected): an empty or dark frame, or the robot not on the carpet",
        floor_colour.u, floor_colour.v, floor_colour.luma_lo, floor_colour.luma_hi,
        100 * out.floor.share, params.floor_from_m, params.floor_to_m,
        100 * params.min_floor_share));
  }
}

void FromImages::findLines() {
  ridge_mask.assign(frames.size(), std::vector<std::uint8_t>(n, 0));
  RidgeParams rp;
  rp.centre = mirror.params().centre;
  rp.min_radius = mirror.params().self_radius + 2.0;
  rp.max_radius = mirror.params().useful_radius;
  rp.min_contrast = 10.0;
  rp.min_ratio = params.min_line_ratio;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    GreyImage grey{w, h, std::vector<std::uint8_t>(n)};
    for (std::size_t i = 0; i < n; ++i)
      grey.pixels[i] = planes[f][i].y;
    for (const Ridge& r : findRidges(grey, rp))
      addLineRidge(f, r);
  }
}

void FromImages::addLineRidge(std::size_t f, const Ridge& r) {
  ++out.ridges;
  const int u = static_cast<int>(std::lround(r.pixel.x()));
  const int v = static_cast<int>(std::lround(r.pixel.y()));
  if (u < 0 || v < 0 || u >= w || v >= h) return;
  const std::size_t i = static_cast<std::size_t>(v) * w + u;
  const double d = geo.distance[i];
  if (!(d <= params.max_line_distance)) return;
  const double expected = field.lineWidth() / std::max(1e-4, geo.mpp_min[i]);
  if (r.width > params.max_width_factor * expected + params.blur_px) return;
  bool flanksFloor = true;
  for (int side : {-1, 1}) {
    const Vec2 q = r.pixel + side * (r.half_width + 1.0) * r.normal;
    const int qu = static_cast<int>(std::lround(q.x())), qv = static_cast<int>(std::lround(q.y()));
    if (qu < 0 || qv < 0 || qu >= w || qv >= h ||
        !isFloor(planes[f][static_cast<std::size_t>(qv) * w + qu])) {
      flanksFloor = false;
    }
  }
  if (!flanksFloor) return;
  ++out.line_ridges;
  floor_luma_near.push_back(r.flank);
  // Samples: across the ridge while at least 75 % of the way from the flank to the peak.
  const double cut = r.flank + 0.75 * (r.peak - r.flank);
  for (double t = -r.half_width; t <= r.half_width + 1e-9; t += 1.0) {
    const Vec2 q = r.pixel + t * r.normal;
    const int qu = static_cast<int>(std::lround(q.x())), qv = static_cast<int>(std::lround(q.y()));
    if (qu < 0 || qv < 0 || qu >= w || qv >= h) continue;
    const std::size_t qi = static_cast<std::size_t>(qv) * w + qu;
    if (planes[f][qi].y >= cut) out.samples.line.push_back(planes[f][qi]);
  }
  // Around the ridge nothing is floor (its blurred edges mix with the paint).
  const double reach = r.width / 2 + 2.0;
  for (double t = -reach; t <= reach + 1e-9; t += 0.5) {
    const Vec2 q = r.pixel + t * r.normal;
    const int qu = static_cast<int>(std::lround(q.x())), qv = static_cast<int>(std::lround(q.y()));
    if (qu < 0 || qv < 0 || qu >= w || qv >= h) continue;
    for (int du = -1; du <= 1; ++du) {
      for (int dv = -1; dv <= 1; ++dv) {
        const int a = qu + du, b = qv + dv;
        if (a >= 0 && b >= 0 && a < w && b < h)
          ridge_mask[f][static_cast<std::size_t>(b) * w + a] = 1;
      }
    }
  }
}

void FromImages::sampleFloor() {
  for (std::size_t f = 0; f < frames.size(); ++f) {
    for (std::size_t i = 0; i < n; ++i) {
      const double d = geo.distance[i];
      if (!(d >= params.floor_from_m && d <= params.max_line_distance)) continue;
      if (ridge_mask[f][i] || !isFloor(planes[f][i])) continue;
      out.samples.floor.push_back(planes[f][i]);
    }
  }
  if (static_cast<int>(out.samples.floor.size()) < params.min_floor_samples) {
    throw Refusal(
        fmt::format("only {} floor pixels found (at least {}): the frames show too "
                    "little floor",
                    out.samples.floor.size(), params.min_floor_samples));
  }
  std::vector<double> fus, fvs;
  for (const Yuv& c : out.samples.floor) {
    fy.push_back(c.y);
    fus.push_back(c.u);
    fvs.push_back(c.v);
  }
  out.floor.median = {percentileOf(fy, 50.0), percentileOf(fus, 50.0), percentileOf(fvs, 50.0)};
  out.floor.luma = {percentileOf(fy, 1.0), percentileOf(fy, 99.0)};
}

void FromImages::measureLines() {
  if (static_cast<int>(out.samples.line.size()) < params.min_line_samples) {
    throw Refusal(fmt::format(
        "only {} line pixels: the frames show no narrow bright ridges on the floor ({} ridges, "
        "{} with floor on both sides): no lines in view, or lines not brighter than the floor",
        out.samples.line.size(), out.ridges, out.line_ridges));
  }
  std::vector<double> lu, lv;
  for (const Yuv& c : out.samples.line) {
    ly.push_back(c.y);
    lu.push_back(c.u);
    lv.push_back(c.v);
  }
  out.white_point = {percentileOf(lu, 50.0), percentileOf(lv, 50.0)};
  out.line_luma = {percentileOf(ly, 5.0), percentileOf(ly, 95.0)};
  const double lineMedian = percentileOf(ly, 50.0);
  const double besideMedian = percentileOf(floor_luma_near, 50.0);
  if (!(lineMedian >= params.min_line_ratio * besideMedian)) {
    throw Refusal(fmt::format(
        "the lines are not brighter than the floor: line pixels median luma {:.0f}, the floor "
        "beside them {:.0f}",
        lineMedian, besideMedian));
  }
  wu = out.white_point[0];
  wv = out.white_point[1];
  std::vector<double> lc;
  for (const Yuv& c : out.samples.line)
    lc.push_back(chromaDistance(c, wu, wv));
  line_chroma = percentileOf(lc, 95.0) + 2.0;
}

void FromImages::keepBallSamples(const std::function<bool(double, double, double)>& floorOrLine) {
  // The samples the ball class is learned from are the ones reported; the others counted.
  std::vector<Yuv> kept;
  for (const Yuv& c : out.samples.ball) {
    if (!floorOrLine(c.y, c.u, c.v)) kept.push_back(c);
  }
  out.ball_samples_refused = static_cast<int>(out.samples.ball.size() - kept.size());
  out.samples.ball = std::move(kept);
  // As when too few ball pixels were found: no ball class rather than one from a handful.
  if (out.samples.ball.size() < 5) out.ball_found = false;
}

void FromImages::fitFloorCone() {
  floor_cone = coneOf(out.samples.floor, wu, wv, params.light_range, 4.0, 0.5, 99.5);
  floor_cone_fitted = true;
}

void FromImages::requireFloorCone(const char* stage) const {
  if (!floor_cone_fitted) {
    throw std::logic_error(fmt::format("colour calibration: {} before fitFloorCone", stage));
  }
}

void FromImages::buildTable() {
  requireFloorCone("buildTable");
  const std::array<double, 2> light = params.light_range;
  const Cone& floorCone = floor_cone;
  Cone whiteCone = coneOf(out.samples.line, wu, wv, {light[0], 10.0}, 6.0, 2.0, 100.0);
  whiteCone.y_hi = 255.0;
  // Where floor and white share chroma (a grey carpet, a washed-out camera), luma decides: floor
  // up to the brightest floor pixels (so that the bright side of an unevenly lit carpet does not
  // turn white and break the green regions with false lines), white from there on; a gap of
  // unclassified luma between them where the lines' dim edges and far lines are as bright as the
  // brightest floor (the tracker's ridge rule finds lines through unclassified pixels).
  const double floorTop = percentileOf(fy, 99.8) + 2.0;
  const double whiteBottom = std::max(floorTop + 4.0, percentileOf(ly, 2.0));
  out.luma_boundary = floorTop;
  out.white_from = whiteBottom;
  // A line is brighter than the floor beside it: nothing darker than the brightest floor is white
  // (a grey floor beyond the carpet, a grey wall), whatever its chroma.
  whiteCone.y_lo = std::max(whiteCone.y_lo, floorTop + 2.0);
  // Where a line's edge meets the carpet, pixels mix the two: chroma on the way from the white
  // point to the floor's, at any luma from the floor's to the line's (in YUYV two neighbouring
  // pixels share one chroma, so an edge pixel may carry one side's luma and the mixed chroma).
  // Those colours are no ball's: neither its samples (a ball lying on a line joins the line's
  // pixels beside it to its blob) nor its cells, or a ball on a line grows along the line's edge.
  const Vec2 whitePoint(wu, wv);
  const Vec2 floorEnd = whitePoint + floorCone.y_hi * Vec2(floorCone.ru, floorCone.rv);
  const auto floorOrLine = [&](double y, double u, double v) {
    if (floorCone.contains(y, u, v, wu, wv) || whiteCone.contains(y, u, v, wu, wv)) return true;
    if (y < floorCone.y_lo) return false;
    const Vec2 seg = floorEnd - whitePoint, c = Vec2(u, v) - whitePoint;
    const double t = std::clamp(c.dot(seg) / std::max(1e-9, seg.squaredNorm()), 0.0, 1.0);
    return (c - t * seg).norm() <= floorCone.radius;
  };
  std::optional<Cone> ballCone;
  if (out.ball_found) {
    keepBallSamples(floorOrLine);
    if (out.ball_found) ballCone = coneOf(out.samples.ball, wu, wv, light, 5.0, 1.0, 99.0);
  }
  std::optional<Cone> blackCone;
  if (!out.samples.robot.empty() && out.samples.robot.size() >= 20) {
    blackCone = coneOf(out.samples.robot, wu, wv, {0.0, 1.3}, 10.0, 0.0, 99.0);
    blackCone->y_hi = std::min(blackCone->y_hi, floorCone.y_lo - 1.0);
  }
  std::vector<ColourClass> cells(static_cast<std::size_t>(camera::ColourTable::kCells),
                                 ColourClass::kUnknown);
  const int bits = camera::ColourTable::kIndexBits;
  const int levels = 1 << bits;
  const double cell = 256.0 / levels;
  for (int iy = 0; iy < levels; ++iy) {
    const double y = (iy + 0.5) * cell;
    for (int iu = 0; iu < levels; ++iu) {
      const double u = (iu + 0.5) * cell;
      for (int iv = 0; iv < levels; ++iv) {
        const double v = (iv + 0.5) * cell;
        ColourClass c = ColourClass::kUnknown;
        const bool inFloor = floorCone.contains(y, u, v, wu, wv);
        const bool inWhite = whiteCone.contains(y, u, v, wu, wv);
        if (inFloor && inWhite) {
          c = y <= floorTop      ? ColourClass::kGreen
              : y >= whiteBottom ? ColourClass::kWhite
                                 : ColourClass::kUnknown;
        } else if (inFloor) {
          c = ColourClass::kGreen;
        } else if (inWhite) {
          c = ColourClass::kWhite;
        } else if (ballCone && ballCone->contains(y, u, v, wu, wv) && !floorOrLine(y, u, v)) {
          c = ColourClass::kOrange;
        } else if (blackCone && blackCone->contains(y, u, v, wu, wv)) {
          c = ColourClass::kBlack;
        }
        cells[(static_cast<std::size_t>(iy) << (2 * bits)) |
              (static_cast<std::size_t>(iu) << bits) | static_cast<std::size_t>(iv)] = c;
      }
    }
  }
  out.table = camera::ColourTable::fromLookup(std::move(cells));
}

}  // namespace imagefit

perception::LinePoints trackLines(const camera::MirrorModel& mirror,
                                  const camera::ColourTable& table,
                                  const camera::FrameView& frame) {
  region_tracking::FrameProcessor processor(mirror, table, region_tracking::defaultVisionParams());
  region_tracking::VisionResult result;
  for (int i = 0; i < 3; ++i)
    processor.process(frame, i == 2, result);
  return result.lines;
}

ImageCalibration calibrateFromImages(const camera::MirrorModel& mirror,
                                     const field::FieldModel& field,
                                     const std::vector<camera::FrameView>& frames,
                                     const std::vector<std::optional<geometry::Pose2>>& poses,
                                     const ImageFitParams& params) {
  if (frames.empty()) throw std::invalid_argument("colour calibration: no frames");
  for (const camera::FrameView& f : frames) {
    if (!f.valid() || f.width != mirror.width() || f.height != mirror.height()) {
      throw std::invalid_argument(
          fmt::format("colour calibration: a frame is {}x{}, the camera model expects {}x{}",
                      f.width, f.height, mirror.width(), mirror.height()));
    }
  }
  if (!poses.empty() && poses.size() != frames.size()) {
    throw std::invalid_argument("colour calibration: one pose per frame, or none");
  }
  imagefit::FromImages s(mirror, field, frames, poses, params);
  s.findFloor();
  s.findLines();
  s.sampleFloor();
  s.measureLines();
  s.fitFloorCone();
  s.findBallAndRobots();
  s.buildTable();
  return std::move(s.out);
}

TableCheck checkTable(const camera::MirrorModel& mirror, const field::FieldModel& field,
                      const std::vector<camera::FrameView>& frames,
                      const camera::ColourTable& table, const ImageFitParams& params) {
  TableCheck check;
  const fusion::LineMatcher matcher(field, fusion::withCalibratedCamera({}));
  std::vector<double> whiteY, greenY;
  long within = 0, total = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    FrameCheck fc;
    const perception::LinePoints lines = trackLines(mirror, table, frames[f]);
    fc.line_points = static_cast<int>(lines.points.size());
    check.line_points += fc.line_points;
    if (fc.line_points >= 10) {
      const std::vector<fusion::PoseCorrection> found = matcher.globalSearch(lines.points);
      if (!found.empty()) {
        fc.localized = true;
        fc.pose = found.front().pose;
        std::vector<double> d;
        int near = 0;
        for (const perception::LinePoint& p : lines.points) {
          const double e = field.distance(geometry::pointRobotToField(fc.pose, Vec2(p.x, p.y)));
          d.push_back(e);
          near += e <= params.fit_distance_m ? 1 : 0;
          fc.on_line.push_back(e <= params.fit_distance_m);
        }
        fc.median_cm = 100.0 * percentileOf(d, 50.0);
        fc.fit_share = static_cast<double>(near) / static_cast<double>(d.size());
        within += near;
        total += static_cast<long>(d.size());
      }
    }
    for (int v = 0; v < frames[f].height; v += 2) {
      for (int u = 0; u < frames[f].width; u += 2) {
        if (mirror.zone(Vec2(u, v)) != camera::MirrorZone::kUseful) continue;
        const ColourClass c = table.classifyPixel(frames[f], u, v);
        if (c == ColourClass::kWhite) whiteY.push_back(camera::readYuv(frames[f], u, v).y);
        if (c == ColourClass::kGreen) greenY.push_back(camera::readYuv(frames[f], u, v).y);
      }
    }
    fc.lines = lines;
    check.frames.push_back(fc);
  }
  check.fit_share = total > 0 ? static_cast<double>(within) / static_cast<double>(total) : 0.0;
  check.white_luma = whiteY.empty() ? 0.0 : percentileOf(whiteY, 50.0);
  check.green_luma = greenY.empty() ? 0.0 : percentileOf(greenY, 50.0);
  if (check.line_points == 0) {
    check.problems.push_back("the table gives no line points in any frame");
  }
  if (greenY.empty() || whiteY.empty() || !(check.white_luma > 1.1 * check.green_luma)) {
    check.problems.push_back(fmt::format(
        "lines are not brighter than the floor with this table (median luma white {:.0f}, "
        "green {:.0f})",
        check.white_luma, check.green_luma));
  }
  for (std::size_t f = 0; f < check.frames.size(); ++f) {
    const FrameCheck& fc = check.frames[f];
    if (fc.line_points < params.min_line_points) {
      check.problems.push_back(fmt::format("frame {}: {} line points (at least {})", f + 1,
                                           fc.line_points, params.min_line_points));
    } else if (!fc.localized || fc.fit_share < params.min_fit_share) {
      check.problems.push_back(fmt::format(
          "frame {}: its line points do not fit field '{}' ({:.0f} % within {:.0f} cm at the "
          "best pose, at least {:.0f} %): frames of another field, or lines found where there "
          "are none",
          f + 1, field.name(), 100 * fc.fit_share, 100 * params.fit_distance_m,
          100 * params.min_fit_share));
    }
  }
  return check;
}

FramesCalibration calibrateColours(const camera::MirrorModel& mirror,
                                   const field::FieldModel& field,
                                   const std::vector<camera::FrameView>& frames,
                                   const ImageFitParams& params) {
  FramesCalibration out;
  out.calibration = calibrateFromImages(mirror, field, frames, {}, params);
  const TableCheck first = checkTable(mirror, field, frames, out.calibration.table, params);
  std::vector<std::optional<geometry::Pose2>> poses;
  for (const FrameCheck& f : first.frames) {
    const bool fits = f.localized && f.fit_share >= params.min_fit_share;
    poses.push_back(fits ? std::optional<geometry::Pose2>(f.pose) : std::nullopt);
    out.posed += fits ? 1 : 0;
  }
  if (out.posed > 0) {
    out.calibration = calibrateFromImages(mirror, field, frames, poses, params);
    out.check = checkTable(mirror, field, frames, out.calibration.table, params);
  } else {
    out.check = first;
  }
  return out;
}

}  // namespace fieldline::calibration
