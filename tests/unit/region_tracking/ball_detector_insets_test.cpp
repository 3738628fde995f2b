// The ball detector's edge-inset table (ball_detector_insets.hpp) sampled cell by cell where a
// ball needs it and shared across detectors (issue 33, session 15: built whole in every
// detector's constructor it cost 79-83 ms of thread CPU at 320x240). It must give exactly the table
// that was built whole: every knot, every angle bin, YUYV or not, bit for bit, including the cells
// without a sphere that take a neighbour's value.
#include "services/region_tracking/ball_detector_insets.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/camera/colour.hpp"
#include "common/camera/mirror_model.hpp"
#include "services/region_tracking/ball_detector.hpp"

namespace fieldline::region_tracking {
namespace ball_detector_insets_test {

// The table as session 14 built it in BallDetector's constructor (3293e72, ball_detector.cpp:
// sampleInsets and buildEdgeInsets, copied unchanged but for names): every knot at once, each
// band's whole box of pixels scanned, empty knots filled by a backward then a forward carry.
bool referenceSample(const camera::MirrorModel& mirror, double r, double horizontal, double bearing,
                     EdgeInsets& plain, EdgeInsets& pairs) {
  const camera::MirrorParams& mp = mirror.params();
  const double H = mp.reference_height;
  const double alpha = std::atan2(H - r, horizontal);
  const double beta = std::asin(std::min(1.0, r / std::hypot(horizontal, H - r)));
  const double nearR = mp.distance.imageRadius(H / std::tan(alpha + beta), bearing);
  const double farR = alpha > beta ? mp.distance.imageRadius(H / std::tan(alpha - beta), bearing)
                                   : std::numeric_limits<double>::quiet_NaN();
  if (!std::isfinite(nearR) || nearR < mp.self_radius) return false;
  const bool hasFar = std::isfinite(farR);
  constexpr double kBand = 4.0;
  const double halfSpan = std::asin(std::min(1.0, r / horizontal)) + 2.0 / nearR;
  const camera::Vec3 centre(horizontal * std::cos(bearing), horizontal * std::sin(bearing), r);
  const camera::Vec3 w0 = camera::Vec3(0, 0, H) - centre;
  const auto hits = [&](int u, int v) {
    const camera::Vec2 pixel(u, v);
    const double b = mirror.bearingOf(pixel);
    const double floor = mp.distance.floorDistance(mirror.radiusOf(pixel), b);
    if (!std::isfinite(floor)) return false;
    const camera::Vec3 dir(floor * std::cos(b), floor * std::sin(b), -H);
    const double bh = dir.dot(w0);
    return bh * bh - dir.squaredNorm() * (w0.squaredNorm() - r * r) >= 0.0;
  };
  double nearPlain = std::numeric_limits<double>::infinity(), nearPair = nearPlain;
  double farPlain = -1, farPair = -1;
  for (int band = 0; band < (hasFar ? 2 : 1); ++band) {
    const double inner = band == 0 ? nearR - 1.5 : farR - kBand;
    const double outer = band == 0 ? nearR + kBand : farR + 1.5;
    double minU = 1e9, maxU = -1e9, minV = 1e9, maxV = -1e9;
    for (const double radius : {inner, outer}) {
      for (const double b : {bearing - halfSpan, bearing, bearing + halfSpan}) {
        const camera::Vec2 p = mp.centre + radius * mirror.imageDirection(b);
        minU = std::min(minU, p.x());
        maxU = std::max(maxU, p.x());
        minV = std::min(minV, p.y());
        maxV = std::max(maxV, p.y());
      }
    }
    for (int v = static_cast<int>(std::floor(minV)) - 1; v <= static_cast<int>(maxV) + 1; ++v) {
      for (int u = static_cast<int>(std::floor(minU)) - 1; u <= static_cast<int>(maxU) + 1; ++u) {
        const double radius = mirror.radiusOf(camera::Vec2(u, v));
        if (radius < inner || radius > outer || !hits(u, v)) continue;
        nearPlain = std::min(nearPlain, radius);
        farPlain = std::max(farPlain, radius);
        if ((radius < nearPair || radius > farPair) && hits(u % 2 == 0 ? u + 1 : u - 1, v)) {
          nearPair = std::min(nearPair, radius);
          farPair = std::max(farPair, radius);
        }
      }
    }
  }
  if (!std::isfinite(nearPair)) return false;
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  plain = {nearPlain - nearR, hasFar ? farR - farPlain : kNaN};
  pairs = {nearPair - nearR, hasFar ? farR - farPair : kNaN};
  return true;
}

struct ReferenceTable {
  double first_m = 0;
  int knots = 0;
  std::vector<EdgeInsets> insets;     // [(yuyv * 4 + bin) * knots + knot]
  int empty_near = 0, empty_far = 0;  // cells that took a neighbour's value
};

ReferenceTable referenceTable(const camera::MirrorModel& mirror, double r) {
  constexpr double kInsetStepM = 0.2;
  constexpr int kInsetAngleBins = 4;
  constexpr int kInsetSamples = 128;
  constexpr double kInsetMaxM = 25.0;
  const auto insetAngleBin = [](const camera::Vec2& direction) {
    const double folded = std::atan2(std::abs(direction.y()), std::abs(direction.x()));
    return std::min(kInsetAngleBins - 1,
                    static_cast<int>(folded / (0.5 * std::numbers::pi) * kInsetAngleBins));
  };
  ReferenceTable out;
  const camera::MirrorParams& mp = mirror.params();
  out.first_m = std::max(mp.distance.floorDistance(mp.self_radius, 0.0), 0.0) + r;
  double last = out.first_m;
  for (int k = 0; k < 8; ++k) {
    last = std::max(last, mp.distance.floorDistance(
                              std::min(mp.useful_radius, mp.distance.maxRadius()), k * 0.785));
  }
  if (!std::isfinite(last) || last > kInsetMaxM) last = kInsetMaxM;
  if (!std::isfinite(out.first_m) || out.first_m > last) out.first_m = 0.0;
  out.knots =
      std::max(2, static_cast<int>(std::ceil((last + 0.5 - out.first_m) / kInsetStepM)) + 1);
  struct Sum {
    double near = 0, far = 0;
    int near_n = 0, far_n = 0;
  };
  std::vector<Sum> sums(2 * kInsetAngleBins * out.knots);
  for (int knot = 0; knot < out.knots; ++knot) {
    for (int j = 0; j < kInsetSamples; ++j) {
      const double bearing = 2 * std::numbers::pi * (j + 0.5) / kInsetSamples + 0.1;
      const double jitter = j * 0.6180339887 - std::floor(j * 0.6180339887) - 0.5;
      EdgeInsets plain, pairs;
      if (!referenceSample(mirror, r, out.first_m + (knot + jitter) * kInsetStepM, bearing, plain,
                           pairs)) {
        continue;
      }
      const int bin = insetAngleBin(mirror.imageDirection(bearing));
      for (int yuyv = 0; yuyv < 2; ++yuyv) {
        const EdgeInsets& e = yuyv ? pairs : plain;
        Sum& sum = sums[(yuyv * kInsetAngleBins + bin) * out.knots + knot];
        sum.near += e.near_px;
        ++sum.near_n;
        if (std::isfinite(e.far_px)) {
          sum.far += e.far_px;
          ++sum.far_n;
        }
      }
    }
  }
  out.insets.assign(sums.size(), EdgeInsets{});
  for (int row = 0; row < 2 * kInsetAngleBins; ++row) {
    EdgeInsets carry;
    for (int pass = 0; pass < 2; ++pass) {
      for (int i = 0; i < out.knots; ++i) {
        const int knot = pass == 0 ? out.knots - 1 - i : i;
        const Sum& sum = sums[row * out.knots + knot];
        EdgeInsets& e = out.insets[row * out.knots + knot];
        if (sum.near_n > 0) carry.near_px = sum.near / sum.near_n;
        if (sum.far_n > 0) carry.far_px = sum.far / sum.far_n;
        e = carry;
      }
    }
  }
  for (const Sum& sum : sums) {
    out.empty_near += sum.near_n == 0 ? 1 : 0;
    out.empty_far += sum.far_n == 0 ? 1 : 0;
  }
  return out;
}

camera::MirrorModel presetMirror(const std::string& preset, int width) {
  const camera::MirrorModel mirror = camera::loadCameraPreset(preset).mirror;
  return mirror.width() == width ? mirror : mirror.scaledTo(width, width * 3 / 4);
}

// The lazy table, its cells asked for in an order unlike the eager build's (the far knots of one
// angle bin first, as a far ball would), against the reference, bit for bit.
void expectEqualToTheEagerTable(const camera::MirrorModel& mirror) {
  constexpr double r = 0.11;
  const ReferenceTable reference = referenceTable(mirror, r);
  const EdgeInsetTable table(mirror, r);
  ASSERT_EQ(table.knots(), reference.knots);
  ASSERT_EQ(table.firstKnotM(), reference.first_m);
  EXPECT_EQ(table.cellsSampled(), 0) << "nothing is sampled before a lookup";
  (void)table.at(reference.first_m + (reference.knots - 3.5) * EdgeInsetTable::kStepM, 0.4, true);
  EXPECT_GT(table.cellsSampled(), 0);
  EXPECT_LT(table.cellsSampled(), EdgeInsetTable::kAngleBins * reference.knots);
  int compared = 0;
  for (int bin = EdgeInsetTable::kAngleBins - 1; bin >= 0; --bin) {
    for (int i = 0; i < reference.knots; ++i) {
      const int knot = (i * 7 + bin) % reference.knots;  // 7 and knots coprime or not: all
      for (int yuyv = 0; yuyv < 2; ++yuyv) {
        const EdgeInsets lazy = table.cell(bin, knot, yuyv == 1);
        const EdgeInsets& eager =
            reference.insets[(yuyv * EdgeInsetTable::kAngleBins + bin) * reference.knots + knot];
        EXPECT_EQ(lazy.near_px, eager.near_px) << "bin " << bin << " knot " << knot;
        EXPECT_EQ(lazy.far_px, eager.far_px) << "bin " << bin << " knot " << knot;
        ++compared;
      }
    }
  }
  // (i * 7 + bin) % knots visits every knot only when 7 does not divide knots; the rest here.
  for (int bin = 0; bin < EdgeInsetTable::kAngleBins; ++bin) {
    for (int knot = 0; knot < reference.knots; ++knot) {
      for (int yuyv = 0; yuyv < 2; ++yuyv) {
        const EdgeInsets& eager =
            reference.insets[(yuyv * EdgeInsetTable::kAngleBins + bin) * reference.knots + knot];
        ASSERT_EQ(table.cell(bin, knot, yuyv == 1).near_px, eager.near_px);
        ASSERT_EQ(table.cell(bin, knot, yuyv == 1).far_px, eager.far_px);
      }
    }
  }
  EXPECT_EQ(table.cellsSampled(), EdgeInsetTable::kAngleBins * reference.knots);
  std::printf("%dx%d: %d knots from %.3f m, %d cells compared, %d near and %d far cells carried\n",
              mirror.width(), mirror.height(), reference.knots, reference.first_m, compared,
              reference.empty_near, reference.empty_far);
}

TEST(BallEdgeInsets, TheLazyTableIsTheEagerOneAtEveryKnot320) {
  expectEqualToTheEagerTable(presetMirror("omni_sim", 320));
}

TEST(BallEdgeInsets, TheLazyTableIsTheEagerOneAtEveryKnot640) {
  expectEqualToTheEagerTable(presetMirror("omni_sim_640", 640));
}

TEST(BallEdgeInsets, TheLazyTableIsTheEagerOneForACalibrationTableWithEmptyFarKnots) {
  // The robot's measured mirror (8 sectors; the distance ends at the useful radius, so the far
  // knots have no far edge and take a nearer knot's), at 320x240 to keep the test short.
  expectEqualToTheEagerTable(presetMirror("robot_640", 320));
}

TEST(BallEdgeInsets, ADetectorSamplesNothingUntilABallIsPlaced) {
  // The node builds its detector on its first frame and on every change of frame size, on the
  // frame thread: building it must not sample the table (before: 36 knots x 128 spheres).
  // A mirror of its own each run (the table cache is process-wide: --gtest_repeat, or another
  // case of this executable placing a ball with omni_sim_640, would find cells sampled).
  static int run = 0;
  camera::MirrorParams own = presetMirror("omni_sim_640", 640).params();
  own.centre.x() += 1e-3 * ++run;
  const camera::MirrorModel mirror(own);
  const camera::ColourTable colours = camera::loadColourTablePreset("colours_sim");
  const BallDetector detector(colours, mirror, BallParams{});
  EXPECT_EQ(detector.edgeInsetTable().cellsSampled(), 0);
  const EdgeInsets insets = detector.edgeInsets(4.6, 0.4, true);
  EXPECT_EQ(detector.edgeInsetTable().cellsSampled(), 4) << "2 knots x 2 angle bins";
  EXPECT_GT(insets.near_px, 0.5) << "a far ball's near edge lies more than half a pixel out";
  // A second detector of the same camera shares the table and its sampled cells.
  const BallDetector again(colours, mirror, BallParams{});
  EXPECT_EQ(&again.edgeInsetTable(), &detector.edgeInsetTable());
  EXPECT_EQ(again.edgeInsets(4.6, 0.4, true).near_px, insets.near_px);
}

TEST(BallEdgeInsets, AFirstFarBallOnTheRobotsMirrorSamplesOnlyCellsThatCanShowAFarEdge) {
  // robot_640's distance ends at 6 m: from about 3.9 m on a knot's far edge is carried from a
  // nearer knot. Finding it must not scan every knot between (16-26 cells at 5-6 m before).
  for (const double range : {5.0, 6.0}) {
    const EdgeInsetTable table(presetMirror("robot_640", 640), 0.11);
    const EdgeInsets insets = table.at(range, 0.4, true);
    EXPECT_TRUE(std::isfinite(insets.far_px)) << range << " m";
    std::printf("robot_640, first ball at %.1f m: %d cells sampled\n", range, table.cellsSampled());
    EXPECT_LE(table.cellsSampled(), 8) << range << " m: 2 knots x 2 bins and the far edge's knot "
                                       << "in each bin";
  }
}

TEST(BallEdgeInsets, OneTablePerMirrorAndBallHeightIsSharedAndThreadSafe) {
  const camera::MirrorModel mirror = presetMirror("omni_sim", 320);
  const std::shared_ptr<const EdgeInsetTable> a = edgeInsetTableFor(mirror, 0.11);
  EXPECT_EQ(a, edgeInsetTableFor(presetMirror("omni_sim", 320), 0.11));
  EXPECT_NE(a, edgeInsetTableFor(mirror, 0.12));
  EXPECT_NE(a, edgeInsetTableFor(mirror.scaledTo(640, 480), 0.11));
  camera::MirrorParams moved = mirror.params();
  moved.centre.x() += 0.25;
  EXPECT_NE(a, edgeInsetTableFor(camera::MirrorModel(moved), 0.11));
  // Still the same table after the others (the cache keeps the last few).
  EXPECT_EQ(a, edgeInsetTableFor(mirror, 0.11));
  // Two threads asking for the same far cells at once get the values one thread gets alone.
  const EdgeInsetTable fresh(mirror, 0.11);
  std::vector<EdgeInsets> seen[3];
  const auto ask = [](const EdgeInsetTable& table, std::vector<EdgeInsets>& out) {
    for (double d = 3.0; d < 6.0; d += 0.05)
      out.push_back(table.at(d, 0.3 + d, true));
  };
  std::thread one(ask, std::cref(fresh), std::ref(seen[0]));
  std::thread two(ask, std::cref(fresh), std::ref(seen[1]));
  one.join();
  two.join();
  ask(*a, seen[2]);
  ASSERT_EQ(seen[0].size(), seen[2].size());
  ASSERT_EQ(seen[1].size(), seen[2].size());
  for (std::size_t i = 0; i < seen[2].size(); ++i) {
    for (int t = 0; t < 2; ++t) {
      EXPECT_EQ(seen[t][i].near_px, seen[2][i].near_px);
      EXPECT_EQ(seen[t][i].far_px, seen[2][i].far_px);
    }
  }
}

}  // namespace ball_detector_insets_test
}  // namespace fieldline::region_tracking
