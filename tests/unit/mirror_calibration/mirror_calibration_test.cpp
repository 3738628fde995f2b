// The stages of the mirror calibration (tools/mirror_calibrate/mirror_calibration.hpp) on
// synthetic data whose answer is known.
#include "tools/mirror_calibrate/mirror_calibration.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "common/config/config.hpp"
#include "services/camera/camera_config.hpp"
#include "tools/mirror_calibrate/pose_free_solver.hpp"

namespace fieldline::calibration {
namespace mirror_calibration_test {

constexpr double kPi = std::numbers::pi;

camera::MirrorParams simParams() {
  return camera::loadCameraPreset("omni_sim").mirror.params();
}

// Bright anti-aliased circles of 2 px width on a dark image.
GreyImage circles(int w, int h, const Vec2& centre, const std::vector<double>& radii) {
  GreyImage g{w, h, std::vector<std::uint8_t>(static_cast<std::size_t>(w) * h, 60)};
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      double sum = 0.0;
      for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
          const double r = (Vec2(u - 0.375 + 0.25 * i, v - 0.375 + 0.25 * j) - centre).norm();
          double l = 60.0;
          for (double rr : radii)
            if (std::abs(r - rr) <= 1.0) l = 220.0;
          sum += l;
        }
      }
      g.pixels[static_cast<std::size_t>(v) * w + u] = static_cast<std::uint8_t>(sum / 16.0);
    }
  }
  return g;
}

// Ring points as a given mirror images them (exact, no image).
std::vector<RingPoint> exactPoints(const camera::MirrorModel& m,
                                   const std::vector<double>& distances, int perRing) {
  std::vector<RingPoint> pts;
  for (std::size_t k = 0; k < distances.size(); ++k) {
    for (int i = 0; i < perRing; ++i) {
      const double a = 2.0 * kPi * i / perRing;
      const std::optional<Vec2> px = m.robotToImage(distances[k] * Vec2(std::cos(a), std::sin(a)));
      if (px) pts.push_back({*px, static_cast<int>(k)});
    }
  }
  return pts;
}

TEST(MonotoneCurve, ThroughTheKnotsMonotoneAndLinearBeyond) {
  const MonotoneCurve c({0.0, 1.0, 2.0, 4.0}, {0.0, 1.0, 1.0, 5.0});
  EXPECT_DOUBLE_EQ(c(1.0), 1.0);
  EXPECT_DOUBLE_EQ(c(4.0), 5.0);
  // Flat between equal knots (no overshoot), increasing elsewhere.
  EXPECT_NEAR(c(1.5), 1.0, 1e-12);
  double last = c(-0.5);
  for (double x = -0.5; x <= 5.0; x += 0.01) {
    EXPECT_GE(c(x), last - 1e-12);
    last = c(x);
  }
  EXPECT_NEAR(c(6.0) - c(5.0), c(5.0) - c(4.0), 1e-12);  // straight beyond the last knot
  EXPECT_NEAR(c(-1.0) - c(-2.0), c(0.0) - c(-1.0), 1e-12);
  // On a smooth curve the cubic is close between the knots: x^2 from knots 1 apart.
  const MonotoneCurve square({0.0, 1.0, 2.0, 3.0, 4.0}, {0.0, 1.0, 4.0, 9.0, 16.0});
  EXPECT_NEAR(square(2.5), 6.25, 0.01);
  EXPECT_THROW(MonotoneCurve({0.0, 0.0}, {0.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(MonotoneCurve({0.0, 1.0}, {1.0, 0.0}), std::invalid_argument);
}

TEST(RingPeaks, SubPixelRadiiOfCirclesAndTheirTracing) {
  const Vec2 centre(101.3, 98.6);
  const std::vector<double> radii{30.0, 45.5, 58.0, 68.0, 75.5};
  const GreyImage g = circles(200, 200, centre, radii);
  RingSearchParams p;
  p.min_radius = 15.0;
  p.max_radius = 90.0;
  // Searched from a guess 2 px off: the peaks still lie on the circles.
  const std::vector<RingPeak> peaks = findRingPeaks(g, centre + Vec2(1.5, -1.2), p);
  ASSERT_GT(peaks.size(), 5u * 300u);
  int onCircle = 0;
  for (const RingPeak& k : peaks) {
    const double r = (k.pixel - centre).norm();
    for (double rr : radii)
      if (std::abs(r - rr) < 0.25) ++onCircle;
  }
  EXPECT_GT(onCircle, static_cast<int>(peaks.size() * 95 / 100));
  const std::vector<TracedRing> rings = traceRings(peaks, p.rays, centre + Vec2(1.5, -1.2));
  ASSERT_EQ(rings.size(), radii.size());
  for (std::size_t k = 0; k < radii.size(); ++k) {
    EXPECT_NEAR(rings[k].radius, radii[k], 0.15);
    EXPECT_LT((rings[k].centre - centre).norm(), 0.15);
  }
  RingSearchParams bad = p;
  bad.rays = 2;
  EXPECT_THROW((void)findRingPeaks(g, centre, bad), std::invalid_argument);
}

TEST(RingMatch, FindsWhichRingIsWhichDistance) {
  const camera::MirrorModel m(simParams());
  const std::vector<double> all{1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0};
  std::vector<double> radii;
  for (double d : all)
    radii.push_back(m.params().distance.imageRadius(d, 0.0));
  // All visible.
  RingMatch r = matchRings(radii, all);
  EXPECT_EQ(r.first_ring, 0);
  EXPECT_EQ(r.first_distance, 0);
  EXPECT_EQ(r.count, 8);
  // The innermost two hidden (under the robot): the rest are 2 m and beyond.
  r = matchRings(std::vector<double>(radii.begin() + 2, radii.end()), all);
  EXPECT_EQ(r.first_distance, 2);
  EXPECT_EQ(r.count, 6);
  // The outermost two not resolved.
  r = matchRings(std::vector<double>(radii.begin(), radii.end() - 2), all);
  EXPECT_EQ(r.first_distance, 0);
  EXPECT_LT(r.misfit, 0.01);
  EXPECT_THROW((void)matchRings({10.0, 20.0, 30.0}, all), std::invalid_argument);
}

TEST(RingGeometry, DistanceAlongARayFromAnOffsetAxis) {
  EXPECT_DOUBLE_EQ(axisDistanceToRing(2.0, 0.3, Vec2::Zero()), 2.0);
  // Axis 0.1 m ahead: the ring is 1.9 m ahead of it and 2.1 m behind it.
  EXPECT_NEAR(axisDistanceToRing(2.0, 0.0, Vec2(0.1, 0.0)), 1.9, 1e-12);
  EXPECT_NEAR(axisDistanceToRing(2.0, kPi, Vec2(0.1, 0.0)), 2.1, 1e-12);
  EXPECT_NEAR(axisDistanceToRing(2.0, kPi / 2, Vec2(0.1, 0.0)), std::sqrt(4.0 - 0.01), 1e-12);
  const camera::MirrorParams p = simParams();
  const Vec2 px = p.centre + 40.0 * camera::MirrorModel(p).imageDirection(0.7);
  EXPECT_NEAR(axisBearing(px, p.centre, p.heading_angle, p.mirrored), 0.7, 1e-12);
}

TEST(RingFit, RecoversCentreOffsetAndRadiiFromExactPoints) {
  camera::MirrorParams truth = simParams();
  truth.centre += Vec2(2.2, -1.7);
  truth.axis_offset = Vec2(0.07, -0.05);
  const camera::MirrorModel m(truth);
  const std::vector<double> d{1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0};
  std::vector<RingPoint> pts = exactPoints(m, d, 180);
  // A few wild points: the fit drops them.
  std::mt19937 rng(3);
  for (int i = 0; i < 40; ++i)
    pts[static_cast<std::size_t>(rng() % pts.size())].pixel += Vec2(6.0, -5.0);
  std::vector<double> start;
  for (double x : d)
    start.push_back(simParams().distance.imageRadius(x, 0.0) + 1.5);
  const RingFit fit = fitRings(pts, d, truth, simParams().centre, start, {});
  // Not exact: the cubic between the rings is not the true mirror law (linear, then exponential
  // from 1.2 m), and the offset moves ring points up to 7 cm off the rings' distances.
  EXPECT_LT((fit.centre - truth.centre).norm(), 0.1);
  EXPECT_LT((fit.axis_offset - truth.axis_offset).norm(), 0.005);
  for (std::size_t k = 0; k < d.size(); ++k)
    EXPECT_NEAR(fit.radii[k], truth.distance.imageRadius(d[k], 0.0), 0.1);
  EXPECT_GE(fit.outliers, 35);
  EXPECT_LT(fit.rms_px, 0.15);
  // Without fitting the offset the centre absorbs part of it and the rms grows.
  RingFitParams noOffset;
  noOffset.fit_offset = false;
  const RingFit plain = fitRings(pts, d, truth, simParams().centre, start, noOffset);
  EXPECT_EQ(plain.axis_offset, Vec2::Zero());
  EXPECT_GT(plain.rms_px, 5 * fit.rms_px);
  EXPECT_THROW((void)fitRings(pts, d, truth, truth.centre, {1.0, 2.0}, {}), std::invalid_argument);
}

TEST(SectorTable, FollowsAMirrorThatIsNotRound) {
  // An elliptic mirror: 4 % longer toward the sides than ahead and behind (a centre shift cannot
  // absorb that).
  camera::MirrorParams truth = simParams();
  camera::CalibrationTableParams t;
  for (double r = 2.0; r <= 140.0; r += 2.0)
    t.radii.push_back(r);
  t.sector_bearings = {-kPi / 2, 0.0, kPi / 2, kPi};
  for (double stretch : {1.04, 0.96, 1.04, 0.96}) {
    std::vector<double> d;
    for (double r : t.radii)
      d.push_back(stretch * simParams().distance.floorDistance(r, 0.0));
    t.distances.push_back(d);
  }
  truth.distance = camera::DistanceFunction(t);
  const camera::MirrorModel m(truth);
  const std::vector<double> d{1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0};
  const std::vector<RingPoint> pts = exactPoints(m, d, 360);
  std::vector<double> start;
  for (double x : d)
    start.push_back(simParams().distance.imageRadius(x, 0.0));
  RingFitParams noOffset;
  noOffset.fit_offset = false;
  const RingFit fit = fitRings(pts, d, truth, truth.centre, start, noOffset);
  const SectorTable round = sectorTable(fit, pts, truth, 1, 2.0);
  const SectorTable eight = sectorTable(fit, pts, truth, 8, 2.0);
  ASSERT_EQ(eight.residuals.size(), 8u);
  EXPECT_GT(round.total.max_percent, 2.0);
  EXPECT_LT(eight.total.rms_percent, 0.8);
  EXPECT_LT(eight.total.max_percent, 2.0);
  for (const SectorResidual& r : eight.residuals) {
    EXPECT_GT(r.points, 100);
    EXPECT_EQ(r.rings, 7);
  }
  EXPECT_NO_THROW(camera::DistanceFunction{eight.table});
}

TEST(MirrorCalibrationFiles, DistancesFromAConfAndAList) {
  const std::filesystem::path conf =
      std::filesystem::temp_directory_path() / "fieldline_rings_test.conf";
  {
    std::ofstream f(conf);
    f << "[Dist]\n\tdist0 = 0\n\tdist1 = 1000\n\tdist2 = 1500\n\tdist3 = 2000\n[!Dist]\n";
  }
  EXPECT_EQ(parseDistances(conf.string()), (std::vector<double>{1.0, 1.5, 2.0}));
  std::filesystem::remove(conf);
  EXPECT_EQ(parseDistances("2,1,1.5"), (std::vector<double>{1.0, 1.5, 2.0}));
  EXPECT_THROW((void)parseDistances("1,x"), std::invalid_argument);
  EXPECT_THROW((void)parseDistances("1,-2"), std::invalid_argument);
  EXPECT_THROW((void)parseDistances("1,1"), std::invalid_argument);
}

TEST(MirrorCalibrationFiles, WrittenPresetLoadsWithoutARenderSection) {
  camera::MirrorParams p = simParams();
  p.axis_offset = Vec2(0.05, -0.02);
  camera::CalibrationTableParams t;
  t.radii = {20.0, 60.0, 140.0};
  t.sector_bearings = {0.0, kPi};
  t.distances = {{0.4, 1.2, 6.0}, {0.41, 1.25, 6.2}};
  p.distance = camera::DistanceFunction(t);
  const std::string yaml = cameraYaml(p, "colours_sim", 30.0, 0.008, 0.06, "test\nsecond line");
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "fieldline_mirror_written.yaml";
  {
    std::ofstream f(file);
    f << yaml;
  }
  const camera::CameraConfig c = camera::loadCameraConfigPreset(file.string());
  std::filesystem::remove(file);
  EXPECT_FALSE(c.render.has_value());
  const camera::MirrorParams& q = c.model.mirror.params();
  EXPECT_LT((q.axis_offset - p.axis_offset).norm(), 1e-9);
  EXPECT_LT((q.centre - p.centre).norm(), 1e-3);
  EXPECT_NEAR(q.distance.floorDistance(100.0, kPi), p.distance.floorDistance(100.0, kPi), 1e-4);
  // Rendering needs the section: a clear error names the file and what is missing.
  try {
    (void)camera::renderParamsOf(c, "the simulated camera");
    FAIL() << "expected a config error";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("render"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("fieldline_mirror_written.yaml"), std::string::npos);
  }
}

// Session 14 (venue): a frame placed after the search with fewer than 600 robot-frame points had
// its 600 "dense" points indexed past the end of its list (garbage read: a NaN point that stopped
// fieldline-eval-real with "DistanceGrid::distance: non-finite point", depending on what lay
// beyond the list). The spread keeps a short list as it is and takes a long one evenly.
TEST(PoseFreeSearch, AnEvenSpreadOfAShortListIsTheListItself) {
  std::vector<Vec2> pts;
  for (int i = 0; i < 300; ++i)
    pts.emplace_back(0.01 * i, -0.02 * i);
  const std::vector<Vec2> some = posefree::evenlySpread(pts, 600);
  ASSERT_EQ(some.size(), pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)
    EXPECT_EQ(some[i], pts[i]);
  for (int i = 300; i < 1000; ++i)
    pts.emplace_back(0.01 * i, -0.02 * i);
  const std::vector<Vec2> spread = posefree::evenlySpread(pts, 600);
  ASSERT_EQ(spread.size(), 600u);
  for (std::size_t i = 0; i < spread.size(); ++i) {
    EXPECT_EQ(spread[i], pts[i * 1000 / 600]);
  }
}

// A point the distance grid cannot measure is refused and counted before the search or a cost
// sees it (the grid throws for one: that ended a whole fieldline-eval-real run).
TEST(PoseFreeSearch, NonFinitePointsAreRefusedAndCountedNotMeasured) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<Vec2> pts = {Vec2(1.0, 0.5), Vec2(nan, 3e-321), Vec2(2.0, -1.0), Vec2(inf, 0)};
  int refused = 0;
  const std::vector<Vec2> kept = posefree::finitePoints(pts, refused);
  EXPECT_EQ(refused, 2);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0], pts[0]);
  EXPECT_EQ(kept[1], pts[2]);
  const field::FieldModel msl = field::loadFieldPreset("msl");
  const field::DistanceGrid grid(msl, 0.05, 1.0);
  EXPECT_THROW((void)grid.distance(pts[1]), std::invalid_argument);
  // A pose that is not finite costs "nothing fits" instead of throwing.
  EXPECT_DOUBLE_EQ(posefree::poseCost(kept, geometry::Pose2{nan, 0.0, 0.0}, grid, 0.15), 1.0);
  EXPECT_LT(posefree::poseCost(kept, geometry::Pose2{0.0, 0.0, 0.0}, grid, 0.15), 1.0);
}

// The field's line centres within `reach` of `pose`, `step` apart, in the robot frame.
std::vector<Vec2> linesSeenFrom(const field::FieldModel& field, const geometry::Pose2& pose,
                                double reach, double step) {
  std::vector<Vec2> out;
  const double c = std::cos(pose.phi), s = std::sin(pose.phi);
  for (const Vec2& p : field.sampleLines(step)) {
    const Vec2 d = p - pose.position();
    if (d.norm() > reach) continue;
    out.emplace_back(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
  }
  return out;
}

// Session 15 (review 14, L9): the frames placed after the search, where session 14's read past
// the end was. A frame with fewer than 600 points is refined with its own points and no others
// (the old loop took 600, past the end of the list), the lattice with 2 x search_points of them
// taken evenly over the whole list; one with more with 600 evenly spread; and the frame comes
// back at the pose its points were seen from (or its twin: the field is symmetric).
TEST(PoseFreeSearch, AFramePlacedAfterTheSearchUsesItsOwnPointsAndComesBackAtItsPose) {
  const field::FieldModel msl = field::loadFieldPreset("msl");
  const PoseFreeParams params;
  const field::DistanceGrid grid(msl, 0.02, 3.0);
  const posefree::CostRaster raster(msl, params.search_truncation, 0.05, 4.0);
  const geometry::Pose2 truth{8.0, 2.0, 0.7};
  const std::size_t want = static_cast<std::size_t>(2 * params.search_points);
  for (const double step : {0.06, 0.01}) {
    SCOPED_TRACE(step);
    const std::vector<Vec2> pts = linesSeenFrom(msl, truth, 3.5, step);
    const posefree::PlacingPoints use = posefree::placingPoints(pts, params);
    if (step > 0.05) {
      ASSERT_LT(pts.size(), 600u);
      ASSERT_GT(pts.size(), want);
      ASSERT_EQ(use.dense.size(), pts.size());
      for (std::size_t i = 0; i < pts.size(); ++i)
        EXPECT_EQ(use.dense[i], pts[i]);
    } else {
      ASSERT_GT(pts.size(), 600u);
      ASSERT_EQ(use.dense.size(), 600u);
      for (std::size_t i = 0; i < use.dense.size(); ++i)
        EXPECT_EQ(use.dense[i], pts[i * pts.size() / 600]);
    }
    ASSERT_EQ(use.coarse.size(), want);
    for (std::size_t i = 0; i < want; ++i)
      EXPECT_EQ(use.coarse[i], pts[i * pts.size() / want]);

    const std::vector<posefree::ScoredPose> found =
        posefree::placeFrame(pts, raster, grid, msl, params, 4);
    ASSERT_FALSE(found.empty());
    geometry::Pose2 best = found.front().pose;
    if (best.x < 0.0) best = posefree::twinOf(best);
    EXPECT_NEAR(best.x, truth.x, 0.03);
    EXPECT_NEAR(best.y, truth.y, 0.03);
    EXPECT_NEAR(geometry::angleDiff(best.phi, truth.phi), 0.0, 0.01);
    EXPECT_LT(found.front().cost, 0.01);
  }
}

}  // namespace mirror_calibration_test
}  // namespace fieldline::calibration
