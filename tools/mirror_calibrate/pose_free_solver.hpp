// The stages of calibrateAtUnknownPose (pose_free.hpp) and the state they share, for the files
// that implement them: pose_free.cpp (stages 1-2: the rim and the line pixels),
// pose_free_search.cpp (stages 3-4: the search over candidate mirrors and poses, the frames at
// one spot linked), pose_free_fit.cpp (stage 5: the joint fit), pose_free_result.cpp (stage 6:
// the offset's verdict, the table per sector, the figures). Internal to the mirror calibration
// library.
#pragma once

#include <cstddef>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "common/camera/mirror_model.hpp"
#include "common/field/distance_grid.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "tools/mirror_calibrate/mirror_calibration.hpp"
#include "tools/mirror_calibrate/pose_free.hpp"

namespace fieldline::calibration::posefree {

using camera::Vec2;
using geometry::Pose2;

// A ridge pixel of one frame with what the fit needs of it.
struct LinePx {
  Vec2 pixel = Vec2::Zero();
  int frame = 0;
  double width = 0.0;           // the ridge's width (above half height), px
  Vec2 across = Vec2::UnitX();  // the direction it was measured in (image)
  double radius = 0.0;          // from the current centre, px
  double bearing = 0.0;         // axis frame, rad
  // Association of the current round.
  Vec2 closest = Vec2::Zero();
  Vec2 normal = Vec2::UnitX();
  double mpp = 0.01;
  bool use = false;
};

// Truncated squared distance to the nearest line, on a raster over the carpet and beyond, for the
// pose lattice: one load per point.
class CostRaster {
 public:
  CostRaster(const field::FieldModel& field, double truncation, double cell, double margin);
  float at(double x, double y) const {
    const int i = static_cast<int>((x - origin_.x()) / cell_ + 0.5);
    const int j = static_cast<int>((y - origin_.y()) / cell_ + 0.5);
    if (i < 0 || j < 0 || i >= cols_ || j >= rows_) return 1.0f;
    return cost_[static_cast<std::size_t>(j) * cols_ + i];
  }

 private:
  double cell_;
  Vec2 origin_;
  int cols_ = 0, rows_ = 0;
  std::vector<float> cost_;
};

// Geman-McClure cost of points seen from `pose` (field frame), mean over points.
double poseCost(const std::vector<Vec2>& pts, const Pose2& pose, const field::DistanceGrid& grid,
                double tau);

Pose2 twinOf(const Pose2& p);

// At most `limit` of `pts`, evenly spread (all of them when there are no more than `limit`).
std::vector<Vec2> evenlySpread(const std::vector<Vec2>& pts, std::size_t limit);

// `pts` without its non-finite points, `refused` counting them: a point the distance grid
// cannot measure never reaches it.
std::vector<Vec2> finitePoints(const std::vector<Vec2>& pts, int& refused);

struct Candidate {
  double k = 1.0;  // radius scale
  double s = 1.0;  // distance scale
};

struct ScoredPose {
  Pose2 pose;
  double cost = 1.0;
};

// The best distinct poses of one frame's points: lattice, then the best refined.
std::vector<ScoredPose> searchPoses(const std::vector<Vec2>& pts, const std::vector<Vec2>& dense,
                                    const CostRaster& raster, const field::DistanceGrid& grid,
                                    const field::FieldModel& field, const PoseFreeParams& params,
                                    int keep);

// A frame placed after the search (its place was ambiguous under the search's rough mirror),
// from its robot-frame points under the fitted mirror: the lattice is scored with
// 2 x search_points of them taken evenly (a short list gives some twice), the best poses refined
// with at most 600, evenly spread (a frame with fewer keeps its own).
struct PlacingPoints {
  std::vector<Vec2> coarse, dense;
};
PlacingPoints placingPoints(const std::vector<Vec2>& pts, const PoseFreeParams& params);
// The best distinct poses of such a frame (searchPoses with placingPoints' lists).
std::vector<ScoredPose> placeFrame(const std::vector<Vec2>& pts, const CostRaster& raster,
                                   const field::DistanceGrid& grid, const field::FieldModel& field,
                                   const PoseFreeParams& params, int keep);

// The curve D(r) through (0, 0) and (radii[k], distances[k]).
MonotoneCurve curveOf(const std::vector<double>& radii, const std::vector<double>& d);

// The radius a pixel's distance is read at: its image radius plus the tilt's share.
double tiltedRadius(const Eigen::VectorXd& v, const Vec2& pixel, const Vec2& ctr);

// The state of the joint fit, packed into one vector:
//   [cx, cy, ox, oy, tx, ty, d_1 .. d_K, per spot: X, Y, per frame: phi or (X, Y, phi)]
// with (tx, ty) the tilt: the image radius a pixel's distance is read at grows by
// tx cos(a) + ty sin(a) px at image angle a (a tilted camera, or a mirror tilted on its mount,
// shifts the horizon toward one side; for an equiangular mirror this is exact).
constexpr int kFirstKnot = 6;
struct Layout {
  int knots = 0;
  std::vector<int> spot_of_frame;  // -1: the frame has its own position
  std::vector<int> frame_index;    // index of the frame's first own parameter
  std::vector<int> spot_index;     // index of each spot's X
  int size = 0;

  int knot(int k) const { return kFirstKnot + k; }
};

Pose2 poseOf(const Eigen::VectorXd& x, const Layout& l, int frame);

// The poses of a group: every candidate pose (and twin) of every member as the anchor, the
// others take their candidate nearest to it; the best total wins. `alternative`: the best
// total with the group elsewhere (1 m or more from it and from its twin): a group whose
// alternative fits about as well is ambiguous (an L of two lines fits at many corners).
struct GroupPoses {
  std::vector<Pose2> poses;
  double total = std::numeric_limits<double>::infinity();
  double alternative = std::numeric_limits<double>::infinity();
};
GroupPoses linkGroup(const std::vector<int>& members,
                     const std::vector<std::vector<ScoredPose>>& found);

// Of a pixel, the sectors whose radii it is read with and the upper one's weight.
struct Blend {
  std::size_t lower = 0, upper = 0;
  double w = 0.0;
};

// One calibration in progress: the stages in the order calibrateAtUnknownPose runs them, each
// reading and writing the shared state below (named as in the stages' description in
// pose_free.hpp).
struct Solver {
  Solver(const std::vector<UnposedFrame>& frames, const field::FieldModel& field,
         const camera::MirrorParams& base_preset, const PoseFreeParams& params);

  // 1. The rim: the centre's first guess and the usable radius.
  void findRim();
  // 2. Ridges with floor on both sides in every frame; Refusal for a frame with too few.
  void findLinePixels();
  void collect();
  // 3. The candidate mirror whose best poses fit the frames best; Refusal when none fits.
  void searchMirrors();
  double scoreCandidate(const Candidate& c, const std::vector<int>& use, int keep,
                        std::vector<std::vector<ScoredPose>>* poses) const;
  void printSearch(const std::vector<Candidate>& candidates,
                   const std::vector<std::pair<double, std::size_t>>& firstScores,
                   double best) const;
  // 4. Frames grouped by spot, each group's poses linked, the seeds of the joint fit.
  void groupFrames();
  void startPoses();
  // 5. The joint fit: its state, whether the offset is fitted, the rounds from a seed, the frames
  // left out placed and fitted in, a spot's misled headings repaired.
  void setUpJointFit();
  void setPoses(const std::vector<int>& which);
  void decideOffset();
  void fitJointly();
  MonotoneCurve curve(const Eigen::VectorXd& v) const;
  bool knotsValid(const Eigen::VectorXd& v) const;
  void smoothness(const double* d, Eigen::VectorXd& res, Eigen::Index at) const;
  Vec2 fieldPoint(const Eigen::VectorXd& v, const MonotoneCurve& c, const LinePx& p,
                  const Vec2& ctr) const;
  int associate(const Eigen::VectorXd& v, const FitRound& round);
  bool residuals(const Eigen::VectorXd& v, Eigen::VectorXd& res) const;
  ResidualFunction residualFunction() const;
  void setSteps(bool offset, bool tilt);
  void runRounds(std::size_t from);
  double shareOnLines() const;
  void fitFromTheBestSeed();
  std::vector<Vec2> robotPoints(int f, std::size_t limit) const;
  double headingAt(int f, const Vec2& at) const;
  void placeWaitingFrames();
  void repairHeadings();
  // 6. The covariance and the offset's verdict, where the table ends, the radii per sector and
  // the table, the figures of the finished model.
  Eigen::MatrixXd covariance(const Eigen::VectorXd& v) const;
  void judgeOffset();
  void findTableEnd();
  void fitSectors();
  bool sectorResiduals(const Eigen::VectorXd& v, Eigen::VectorXd& res) const;
  void writeTable();
  void measure();
  void measureLineWidth(const camera::MirrorModel& model);
  void reportFrames(const std::vector<double>& fpx2, const std::vector<int>& fn,
                    const std::vector<int>& fin);

  const std::vector<UnposedFrame>& frames;
  const field::FieldModel& field;
  const PoseFreeParams& params;
  const int w, h, nf;
  PoseFreeCalibration out;
  camera::MirrorParams base;
  // Stage 1.
  Vec2 centre;
  double usable_radius = 0.0;
  // Stage 2.
  std::vector<std::vector<camera::Yuv>> planes;
  RidgeParams rp;
  std::vector<LinePx> pixels;
  std::vector<int> per_frame;
  // Refusals of non-finite robot-frame points before the pose search or cost (at each use).
  mutable int non_finite_points = 0;
  // Stage 3.
  std::optional<field::DistanceGrid> grid;
  std::optional<CostRaster> raster;
  double search_radius = 0.0;
  Candidate winner;
  std::vector<std::vector<ScoredPose>> winner_poses;
  // Stage 4.
  std::vector<std::vector<int>> groups;
  std::vector<int> spot_of;
  int nspots = 0;
  std::vector<Pose2> start;
  std::vector<bool> active;
  std::vector<std::pair<double, std::size_t>> seeds;  // groups by how well the search placed them
  // Stage 5.
  std::vector<double> kr;  // the knots' image radii
  Layout layout;
  Eigen::VectorXd x;
  Eigen::VectorXd knot_start;
  int priors = 0;
  bool fit_offset = false;
  std::vector<double> steps;
  int used = 0;
  double max_distance = 0.0;
  // Stage 6.
  Eigen::MatrixXd cov;
  std::size_t last_supported = 0;
  int ns = 0, nk = 0;
  std::vector<double> bearings;
  std::vector<Blend> blends;
  Eigen::VectorXd xs;
};

}  // namespace fieldline::calibration::posefree
