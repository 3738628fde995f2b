#include "tools/mirror_calibrate/pose_free.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>

#include "common/geometry/fitting.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/mirror_calibrate/numbers.hpp"
#include "tools/mirror_calibrate/pose_free_solver.hpp"

namespace fieldline::calibration {

using camera::Vec2;

camera::MirrorParams scaleMirrorTo(const camera::MirrorParams& base, int width, int height) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("image size must be > 0");
  if (width == base.width && height == base.height) return base;
  const double factor =
      static_cast<double>(std::min(width, height)) / std::min(base.width, base.height);
  camera::MirrorParams p = base;
  p.width = width;
  p.height = height;
  const Vec2 oldMiddle(base.width / 2.0 - 0.5, base.height / 2.0 - 0.5);
  const Vec2 newMiddle(width / 2.0 - 0.5, height / 2.0 - 0.5);
  p.centre = newMiddle + (base.centre - oldMiddle) * factor;
  p.outer_radius *= factor;
  p.useful_radius *= factor;
  p.self_radius *= factor;
  p.distance = base.distance.scaled(factor);
  return p;
}

std::optional<Rim> findMirrorRim(const GreyImage& image, const Vec2& guess, double min_radius,
                                 double max_radius) {
  constexpr int kRays = 180;
  constexpr double kStep = 0.5;
  std::vector<Vec2> pts;
  for (int ray = 0; ray < kRays; ++ray) {
    const double a = 2 * kPi * ray / kRays;
    const Vec2 dir(std::cos(a), std::sin(a));
    std::vector<double> prof;
    for (double r = min_radius; r <= max_radius; r += kStep) {
      const Vec2 q = guess + r * dir;
      const double s = image.sample(q.x(), q.y());
      if (!std::isfinite(s)) break;
      prof.push_back(s);
    }
    const int n = static_cast<int>(prof.size());
    const int inside = static_cast<int>(8 / kStep);
    const int outside = static_cast<int>(6 / kStep);
    // The first place outward where the image drops to dark and stays dark to the end of the
    // ray (at least 6 px of it): beyond the mirror.
    std::vector<double> suffixMax(static_cast<std::size_t>(n) + 1, 0.0);
    for (int i = n - 1; i >= 0; --i)
      suffixMax[static_cast<std::size_t>(i)] =
          std::max(suffixMax[static_cast<std::size_t>(i) + 1], prof[static_cast<std::size_t>(i)]);
    for (int i = inside; i + outside < n; ++i) {
      double in = 0.0;
      for (int k = i - inside; k < i; ++k)
        in += prof[static_cast<std::size_t>(k)];
      in /= inside;
      const double beyond = suffixMax[static_cast<std::size_t>(i) + 2];
      if (in > 45.0 && beyond < 0.45 * in && beyond < 45.0) {
        // Sub-pixel: where the profile crosses halfway between inside and beyond.
        const double halfway = 0.5 * (in + beyond);
        int j = i;
        while (j > i - inside && prof[static_cast<std::size_t>(j)] < halfway)
          --j;
        const double a0 = prof[static_cast<std::size_t>(j)];
        const double a1 = prof[static_cast<std::size_t>(j) + 1];
        const double t = a0 > a1 ? (a0 - halfway) / (a0 - a1) : 0.5;
        pts.push_back(guess + (min_radius + (j + t) * kStep) * dir);
        break;
      }
    }
  }
  if (pts.size() < 30) return std::nullopt;
  Rim rim;
  std::vector<bool> keep;
  if (!geometry::fitCircleRobust(pts, rim.centre, rim.radius, keep, 1.5)) return std::nullopt;
  rim.rays = static_cast<int>(std::count(keep.begin(), keep.end(), true));
  if (rim.rays < 30) return std::nullopt;
  return rim;
}

namespace posefree {

Solver::Solver(const std::vector<UnposedFrame>& frames_in, const field::FieldModel& field_in,
               const camera::MirrorParams& base_preset, const PoseFreeParams& params_in)
    : frames(frames_in),
      field(field_in),
      params(params_in),
      w(frames_in[0].image.width),
      h(frames_in[0].image.height),
      nf(static_cast<int>(frames_in.size())),
      base(scaleMirrorTo(base_preset, w, h)),
      centre(base.centre),
      usable_radius(base.useful_radius),
      per_frame(static_cast<std::size_t>(nf), 0) {}

void Solver::findRim() {
  std::vector<Vec2> centres;
  std::vector<double> radii;
  for (const UnposedFrame& f : frames) {
    if (const std::optional<Rim> rim =
            findMirrorRim(f.image, base.centre, 0.5 * base.outer_radius, std::hypot(w, h) / 2.0)) {
      if (rim->radius > 0.75 * base.outer_radius && rim->radius < 1.3 * base.outer_radius) {
        centres.push_back(rim->centre);
        radii.push_back(rim->radius);
      }
    }
  }
  if (!centres.empty()) {
    std::vector<double> cx, cy;
    for (const Vec2& c : centres) {
      cx.push_back(c.x());
      cy.push_back(c.y());
    }
    out.rim_found = true;
    out.rim_centre = Vec2(geometry::median(cx), geometry::median(cy));
    out.rim_radius = geometry::median(radii);
    centre = out.rim_centre;
    base.outer_radius = out.rim_radius;
    usable_radius = std::min(base.useful_radius, 0.97 * out.rim_radius);
  }
}

void Solver::findLinePixels() {
  // The floor's colour: the dominant colour near the robot (an annulus of image radii inside
  // which any omni-directional camera shows floor). Lines are ridges with floor on both sides;
  // ridges in the hall (people, walls, robots' tops) are not.
  for (const UnposedFrame& f : frames) {
    if (f.colour.size() == f.image.pixels.size()) {
      planes.push_back(f.colour);
    } else {
      std::vector<camera::Yuv> grey(f.image.pixels.size());
      for (std::size_t i = 0; i < grey.size(); ++i)
        grey[i] = camera::Yuv{f.image.pixels[i], 128, 128};
      planes.push_back(std::move(grey));
    }
  }
  {
    std::vector<std::uint8_t> near(static_cast<std::size_t>(w) * h, 0);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const double r = (Vec2(u, v) - centre).norm();
        near[static_cast<std::size_t>(v) * w + u] =
            r >= 1.3 * base.self_radius + 2.0 && r <= 0.55 * usable_radius;
      }
    }
    out.floor = findFloorColour(planes, near, 2);
  }
  rp = params.ridges;
  rp.centre = centre;
  rp.min_radius = std::max(rp.min_radius, 1.15 * base.self_radius + 2.0);
  rp.max_radius = std::min(rp.max_radius, usable_radius);
  collect();
  out.ridge_pixels = static_cast<int>(pixels.size());
  for (int f = 0; f < nf; ++f) {
    if (per_frame[static_cast<std::size_t>(f)] < 100) {
      throw Refusal(fmt::format(
          "{}: only {} bright ridges with floor on both sides (line pixels) between {:.0f} and "
          "{:.0f} px from the centre: an empty, dark or overexposed frame, or no field lines in "
          "view",
          frames[static_cast<std::size_t>(f)].name, per_frame[static_cast<std::size_t>(f)],
          rp.min_radius, rp.max_radius));
    }
  }
  for (LinePx& p : pixels) {
    p.radius = (p.pixel - centre).norm();
    p.bearing = axisBearing(p.pixel, centre, base.heading_angle, base.mirrored);
  }
}

// The ridges of every frame with the floor's colour on both sides, around rp.centre.
void Solver::collect() {
  pixels.clear();
  std::fill(per_frame.begin(), per_frame.end(), 0);
  for (int f = 0; f < nf; ++f) {
    const std::vector<camera::Yuv>& plane = planes[static_cast<std::size_t>(f)];
    for (const Ridge& r : findRidges(frames[static_cast<std::size_t>(f)].image, rp)) {
      bool onFloor = true;
      for (int side : {-1, 1}) {
        const Vec2 q = r.pixel + side * (r.half_width + 1.0) * r.normal;
        const int qu = static_cast<int>(std::lround(q.x()));
        const int qv = static_cast<int>(std::lround(q.y()));
        if (qu < 0 || qv < 0 || qu >= w || qv >= h) {
          onFloor = false;
          continue;
        }
        // The floor's chroma, and its luma within a factor of 1.5 either way of what it is
        // near the robot (vignetting and uneven light darken the far floor).
        const camera::Yuv& c = plane[static_cast<std::size_t>(qv) * w + qu];
        onFloor = onFloor && out.floor.chromaMatches(c) && c.y >= out.floor.luma_lo / 1.5 &&
                  c.y <= out.floor.luma_hi * 1.5;
      }
      if (!onFloor) continue;
      LinePx p;
      p.pixel = r.pixel;
      p.frame = f;
      p.width = r.width;
      p.across = r.normal;
      pixels.push_back(p);
      ++per_frame[static_cast<std::size_t>(f)];
    }
  }
}

}  // namespace posefree

PoseFreeCalibration calibrateAtUnknownPose(const std::vector<UnposedFrame>& frames,
                                           const field::FieldModel& field,
                                           const camera::MirrorParams& base_preset,
                                           const PoseFreeParams& params) {
  if (frames.empty()) throw std::invalid_argument("mirror calibration: no frames");
  const int w = frames[0].image.width;
  const int h = frames[0].image.height;
  for (const UnposedFrame& f : frames) {
    if (f.image.width != w || f.image.height != h) {
      throw std::invalid_argument(fmt::format(
          "mirror calibration: {} is {}x{}, the first frame {}x{}: all frames must come from "
          "one camera",
          f.name, f.image.width, f.image.height, w, h));
    }
  }
  if (params.rounds.empty() || params.radius_scales.empty() || params.distance_scales.empty()) {
    throw std::invalid_argument("mirror calibration: rounds and candidate scales expected");
  }
  posefree::Solver s(frames, field, base_preset, params);
  s.findRim();
  s.findLinePixels();
  s.searchMirrors();
  s.groupFrames();
  s.startPoses();
  s.setUpJointFit();
  s.decideOffset();
  s.fitJointly();
  s.judgeOffset();
  s.findTableEnd();
  s.fitSectors();
  s.writeTable();
  s.measure();
  s.out.search.non_finite_points = s.non_finite_points;
  return std::move(s.out);
}

std::vector<std::string> weaknesses(const PoseFreeCalibration& c, const std::string& field_name) {
  std::vector<std::string> weak;
  if (c.rms_px > 1.0) {
    weak.push_back(fmt::format("rms {:.2f} px to the lines (at most 1)", c.rms_px));
  }
  if (c.on_lines < 0.6) {
    weak.push_back(
        fmt::format("only {:.0f} % of the ridge pixels lie on field lines (at least "
                    "60 %): frames of another field?",
                    100 * c.on_lines));
  }
  for (const FramePose& f : c.frames) {
    if (f.on_lines < 0.45 || f.points < 60) {
      weak.push_back(
          fmt::format("{}: {} line pixels, {:.0f} % of its ridges on lines: it does "
                      "not show field '{}'",
                      f.name, f.points, 100 * f.on_lines, field_name));
    }
  }
  if (c.width_samples >= 30 && (c.line_width_ratio < 0.85 || c.line_width_ratio > 1.25)) {
    weak.push_back(fmt::format(
        "the lines are {:.2f} times as wide as field '{}' paints them (median of {} near line "
        "pixels): frames of another field, or a mirror scaled to fit the wrong one",
        c.line_width_ratio, field_name, c.width_samples));
  }
  if (c.table_end_m < 3.0) {
    weak.push_back(
        fmt::format("the line pixels reach only {:.2f} m (a table to 3 m or more is "
                    "needed): frames with lines further out",
                    c.table_end_m));
  }
  return weak;
}

}  // namespace fieldline::calibration
