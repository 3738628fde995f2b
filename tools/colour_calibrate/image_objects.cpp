// The ball and the robots of the colour calibration from frames (image_stages.hpp): blobs that are
// neither floor nor line inside the field; the dark ones are robots, the colourful ones of a
// ball's image size are balls, and the ball seen in the most frames wins.
#include <algorithm>
#include <cmath>
#include <deque>
#include <numbers>
#include <utility>

#include "tools/colour_calibrate/image_stages.hpp"

namespace fieldline::calibration::imagefit {

namespace {

// The image area of a ball of `radius` resting on the floor at robot-frame `centre`: the convex
// hull of its surface's points projected through the mirror. A ball is seen from above and
// beside, so its image reaches well beyond its disc at mid height (twice its area at 2 m for the
// shipped mirror). Zero when part of it is not imaged.
double ballImageArea(const camera::MirrorModel& mirror, const Vec2& centre, double radius) {
  std::vector<Vec2> pts;
  for (int i = 0; i <= 8; ++i) {
    const double lat = std::numbers::pi * (i / 8.0 - 0.5);
    for (int k = 0; k < 16; ++k) {
      const double lon = 2.0 * std::numbers::pi * k / 16.0;
      const std::optional<Vec2> p = mirror.robotPointToImage(
          {centre.x() + radius * std::cos(lat) * std::cos(lon),
           centre.y() + radius * std::cos(lat) * std::sin(lon), radius + radius * std::sin(lat)});
      if (!p) return 0.0;
      pts.push_back(*p);
    }
  }
  // Monotone chain hull, then the shoelace area.
  std::sort(pts.begin(), pts.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  const auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Vec2> hull(2 * pts.size());
  std::size_t h = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    while (h >= 2 && cross(hull[h - 2], hull[h - 1], pts[i]) <= 0)
      --h;
    hull[h++] = pts[i];
  }
  for (std::size_t i = pts.size() - 1, lower = h + 1; i-- > 0;) {
    while (h >= lower && cross(hull[h - 2], hull[h - 1], pts[i]) <= 0)
      --h;
    hull[h++] = pts[i];
  }
  double area = 0.0;
  for (std::size_t i = 0; i + 1 < h; ++i)
    area += hull[i].x() * hull[i + 1].y() - hull[i + 1].x() * hull[i].y();
  return std::abs(area) / 2.0;
}

}  // namespace

void FromImages::findBallAndRobots() {
  if (poses.empty()) return;
  std::vector<Blob> balls;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    if (!hasPose(f)) continue;
    for (const Blob& b : blobsOf(f, otherMask(f))) {
      // Dark blobs standing in the field: robots.
      if (isRobot(b)) {
        out.robots_found = true;
        for (int p : b.pixels) {
          const Yuv& c = planes[f][static_cast<std::size_t>(p)];
          if (c.y < 0.8 * out.floor.luma[0]) out.samples.robot.push_back(c);
        }
      }
    }
    for (Blob& b : ballBlobs(f))
      balls.push_back(std::move(b));
  }
  chooseBall(balls);
}

std::vector<Blob> FromImages::ballBlobs(std::size_t f) const {
  requireFloorCone("ballBlobs");
  std::vector<std::uint8_t> mask = otherMask(f);
  for (std::size_t i = 0; i < n; ++i) {
    const Yuv& c = planes[f][i];
    if (mask[i] && floor_cone.contains(c.y, c.u, c.v, wu, wv)) mask[i] = 0;
  }
  std::vector<Blob> balls;
  for (Blob& b : blobsOf(f, mask)) {
    if (!isRobot(b) && looksLikeABall(b)) balls.push_back(std::move(b));
  }
  return balls;
}

// Pixels of frame f that are neither floor nor line, inside the field (and within 6 m).
std::vector<std::uint8_t> FromImages::otherMask(std::size_t f) const {
  const double hx = field.length() / 2 + 0.3, hy = field.width() / 2 + 0.3;
  std::vector<std::uint8_t> other(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(geo.distance[i]) || geo.distance[i] > 6.0) continue;
    const Vec2 fp = geometry::pointRobotToField(*poses[f], geo.robot[i]);
    if (std::abs(fp.x()) > hx || std::abs(fp.y()) > hy) continue;
    const Yuv& c = planes[f][i];
    if (isFloor(c)) continue;        // floor
    if (ridge_mask[f][i]) continue;  // a line
    // A line's colour: where a ball lies on a line, the line's ridge beside it has no floor on
    // that flank and is not masked; its pixels would join the ball's blob.
    if (c.y >= out.line_luma[0] && chromaDistance(c, wu, wv) <= line_chroma) continue;
    other[i] = 1;
  }
  return other;
}

// Connected blobs (4-neighbours) of at least 6 pixels, with their statistics.
std::vector<Blob> FromImages::blobsOf(std::size_t f, const std::vector<std::uint8_t>& other) const {
  std::vector<Blob> blobs;
  std::vector<int> label(n, -1);
  for (std::size_t s = 0; s < n; ++s) {
    if (!other[s] || label[s] >= 0) continue;
    Blob b;
    b.frame = static_cast<int>(f);
    std::deque<int> queue{static_cast<int>(s)};
    label[s] = 1;
    while (!queue.empty()) {
      const int p = queue.front();
      queue.pop_front();
      b.pixels.push_back(p);
      const int pu = p % w, pv = p / w;
      const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
      for (const auto& d : nb) {
        const int a = pu + d[0], c = pv + d[1];
        if (a < 0 || c < 0 || a >= w || c >= h) continue;
        const std::size_t q = static_cast<std::size_t>(c) * w + a;
        if (other[q] && label[q] < 0) {
          label[q] = 1;
          queue.push_back(static_cast<int>(q));
        }
      }
    }
    if (b.pixels.size() < 6) continue;
    double su = 0, sv = 0, sy = 0, sc = 0;
    int minU = w, maxU = 0, minV = h, maxV = 0;
    for (int p : b.pixels) {
      const Yuv& c = planes[f][static_cast<std::size_t>(p)];
      su += p % w;
      sv += p / w;
      sy += c.y;
      sc += chromaDistance(c, wu, wv);
      minU = std::min(minU, p % w);
      maxU = std::max(maxU, p % w);
      minV = std::min(minV, p / w);
      maxV = std::max(maxV, p / w);
    }
    const double m = static_cast<double>(b.pixels.size());
    b.centroid = Vec2(su / m, sv / m);
    b.mean_y = sy / m;
    b.chroma = sc / m;
    b.aspect = static_cast<double>(std::max(maxU - minU, maxV - minV) + 1) /
               static_cast<double>(std::min(maxU - minU, maxV - minV) + 1);
    blobs.push_back(b);
  }
  return blobs;
}

// A ball: colourful, not dark, about a ball's image for its distance, compact.
bool FromImages::looksLikeABall(const Blob& b) const {
  const double m = static_cast<double>(b.pixels.size());
  if (b.chroma < 15.0 || b.mean_y < 0.5 * out.floor.median[0]) return false;
  const std::optional<camera::Vec3> centre = mirror.imageToRobotAtHeight(b.centroid, 0.11);
  if (!centre) return false;
  const Vec2 c2(centre->x(), centre->y());
  const double expectedArea = std::max(1.0, ballImageArea(mirror, c2, 0.11));
  if (expectedArea <= 1.0) return false;
  const double ratio = m / expectedArea;
  if (ratio < params.ball_area_low || ratio > params.ball_area_high || b.aspect > 3.0) {
    return false;
  }
  return true;
}

void FromImages::chooseBall(const std::vector<Blob>& balls) {
  // One ball lies at one field position: the blob position seen in the most frames wins. The
  // field is symmetric, so a frame localized at its pose's twin sees the ball at the twin
  // position (-x, -y): both count for the same ball.
  const auto sameBall = [](const Vec2& a, const Vec2& b) {
    return (a - b).norm() < 0.4 || (a + b).norm() < 0.4;
  };
  std::vector<Vec2> at;
  for (const Blob& b : balls) {
    const auto c = mirror.imageToRobotAtHeight(b.centroid, 0.11);
    at.push_back(geometry::pointRobotToField(*poses[static_cast<std::size_t>(b.frame)],
                                             Vec2(c->x(), c->y())));
  }
  int bestVotes = 0;
  std::size_t bestIndex = 0;
  for (std::size_t i = 0; i < balls.size(); ++i) {
    std::vector<bool> framesSeen(frames.size(), false);
    for (std::size_t j = 0; j < balls.size(); ++j) {
      if (sameBall(at[i], at[j])) framesSeen[static_cast<std::size_t>(balls[j].frame)] = true;
    }
    const int votes = static_cast<int>(std::count(framesSeen.begin(), framesSeen.end(), true));
    if (votes > bestVotes) {
      bestVotes = votes;
      bestIndex = i;
    }
  }
  int posed = 0;
  for (std::size_t f = 0; f < frames.size(); ++f)
    posed += hasPose(f) ? 1 : 0;
  const int needed = std::max(1, posed / 3);
  if (bestVotes >= needed) {
    out.ball_found = true;
    out.ball_frames = bestVotes;
    // Where the ball lies: the mean of its sightings (twins turned back).
    Vec2 sum = Vec2::Zero();
    int sightings = 0;
    for (std::size_t j = 0; j < balls.size(); ++j) {
      if (!sameBall(at[bestIndex], at[j])) continue;
      sum += (at[bestIndex] - at[j]).norm() < 0.4 ? at[j] : Vec2(-at[j]);
      ++sightings;
    }
    out.ball_field = sum / sightings;
    for (std::size_t j = 0; j < balls.size(); ++j) {
      if (!sameBall(at[bestIndex], at[j])) continue;
      const Blob& b = balls[j];
      // The inside of the blob (its rim mixes with the floor): pixels whose 4 neighbours are
      // in the blob too.
      std::vector<std::uint8_t> in(n, 0);
      for (int p : b.pixels)
        in[static_cast<std::size_t>(p)] = 1;
      for (int p : b.pixels) {
        const int pu = p % w, pv = p / w;
        if (pu < 1 || pv < 1 || pu >= w - 1 || pv >= h - 1) continue;
        if (in[static_cast<std::size_t>(p - 1)] && in[static_cast<std::size_t>(p + 1)] &&
            in[static_cast<std::size_t>(p - w)] && in[static_cast<std::size_t>(p + w)]) {
          out.samples.ball.push_back(
              planes[static_cast<std::size_t>(b.frame)][static_cast<std::size_t>(p)]);
        }
      }
    }
    if (out.samples.ball.size() < 5) out.ball_found = false;
  }
}

}  // namespace fieldline::calibration::imagefit
