// The ball in regions of the ball's colour (seed 4.9.5): each candidate's size and shape
// against the image of a ball at its distance (3-D mirror model), on the carpet and, with a
// pose, on the field.
#pragma once

#include <memory>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/region_tracking/ball_detector_insets.hpp"
#include "services/region_tracking/contours.hpp"

namespace fieldline::region_tracking {

struct BallParams {
  camera::ColourClass colour = camera::ColourClass::kOrange;
  // Height of the ball's centre above the floor, m (the ball's radius: it lies on the floor).
  double centre_height = 0.11;
  // Fewer orange pixels than this is no ball.
  int min_pixels = 2;
  // Shape: a candidate's radial and tangential extents (px) must lie within
  // [expected / size_tolerance - size_slack_px, expected * size_tolerance + size_slack_px],
  // where `expected` is the image of a ball at the candidate's distance (3-D mirror model).
  double size_tolerance = 1.5;
  double size_slack_px = 1.5;
  // Ball-coloured pixels per pixel of the expected silhouette (ellipse of the expected extents):
  // at least this (a thin streak or a ring is no ball).
  double min_fill = 0.4;
  // On the carpet: of the samples on a ring around the candidate (1.5 times its expected size +
  // 2 px), at least this share must be carpet (field or line colour).
  double min_carpet_share = 0.5;
  camera::ColourClass field_colour = camera::ColourClass::kGreen;
  camera::ColourClass line_colour = camera::ColourClass::kWhite;
  // With a field and a pose (BallRegion): a ball must lie within this of the field's lines
  // (their outer edges), plus the pose's sigma, m. A ball that rolled further out is out of play;
  // orange things beyond the lines are not balls.
  double field_margin_m = 0.3;
};

// Where a ball can be: on the field (field model) seen from the robot's pose, which fusion
// knows with `pose_sigma_m` (position, m). Without one the detector judges by the image alone.
struct BallRegion {
  const field::FieldModel* field = nullptr;
  geometry::Pose2 pose;
  double pose_sigma_m = 0.0;
};

struct BallDetection {
  bool visible = false;
  // Where the ball's centre is seen in the image, px.
  double u = 0, v = 0;
  // Floor point under the ball's centre, robot frame, m.
  double x = 0, y = 0;
  double sigma_radial = 0, sigma_tangential = 0;
  int pixels = 0;
  int cells = 0;
  // Fit of the winning candidate in (0, 1]: carpet share x fill x size agreement.
  double confidence = 0;
  // Ball-coloured regions looked at this frame, and how many of them were refused (too large
  // or too small for a ball at their distance, wrong shape, not on the carpet).
  int candidates = 0;
  int rejected = 0;
};

// Why a candidate was refused (counted per frame in BallDetection::rejected; the reason is for
// tests and tools).
enum class BallReject {
  kNone,
  kTooFewPixels,
  kTooLarge,
  kAtImageBorder,
  kNoFloor,
  kSize,
  kFill,
  kNotOnCarpet,
  kOutsideField
};
inline constexpr int kBallRejectCount = 9;

class BallDetector {
 public:
  // Throws std::invalid_argument for parameters out of range (size_tolerance < 1, slack < 0,
  // min_fill or min_carpet_share outside [0, 1], centre height outside (0, reference height)).
  BallDetector(const camera::ColourTable& table, const camera::MirrorModel& mirror,
               const BallParams& params);
  // Every outer contour of the ball colour in `contours` is a candidate; a candidate is a ball
  // when its size and shape fit a ball at its distance, it lies on the carpet and, with a
  // `region`, on the field; the best fit wins. Candidates cut by the image's border are refused
  // (their size cannot be checked). A table without the ball colour finds no ball.
  BallDetection detect(const camera::FrameView& frame, const ContourSet& contours,
                       const BallRegion* region = nullptr) const;

  // One candidate, with the reason when refused (kNone: `out` holds the detection).
  BallReject evaluate(const camera::FrameView& frame, const ContourSet& contours,
                      const Contour& contour, BallDetection& out,
                      const BallRegion* region = nullptr) const;
  // False when the colour table has no cell of the ball's colour (no ball colour calibrated).
  bool hasBallColour() const { return has_colour_; }

  // Image extents (px) of a ball whose centre is `horizontal` m away at `bearing` (robot
  // frame): radially and across the ray; false where the mirror does not see it.
  bool expectedExtent(double horizontal, double bearing, double& radialPx,
                      double& tangentialPx) const;

  // How far inside the ball's silhouette its outermost ball-coloured pixels lie, px, on average:
  // at the near edge (toward the mirror centre) and the far edge, for a ball whose centre is
  // `horizontal` m away at `bearing`. Two things put them there: the pixels are sampled at their
  // centres (a curved edge's outermost pixel centre lies less than half a pixel in, a straight
  // one's half a pixel), and in a YUYV frame two neighbouring pixels share one chroma sample, so
  // an edge pixel whose pair partner is off the ball has the carpet's chroma mixed in and is not
  // ball-coloured. Derived from the mirror model (silhouettes of spheres at many places and
  // sub-pixel shifts), not measured on frames: ball_detector_insets.hpp, sampled where a ball is
  // first placed and shared by the detectors of the process.
  using EdgeInsets = region_tracking::EdgeInsets;
  EdgeInsets edgeInsets(double horizontal, double bearing, bool yuyv) const {
    return insets_->at(horizontal, bearing, yuyv);
  }
  const EdgeInsetTable& edgeInsetTable() const { return *insets_; }

 private:
  // The steps of evaluate(), in order; each returns kNone or why the candidate is refused.
  // The candidate's box of pixels: its cells' box widened by a pixel, inside the frame.
  struct PixelBox {
    int min_u, min_v, max_u, max_v;
  };
  BallReject boxOf(const camera::FrameView& frame, const ContourSet& contours,
                   const Contour& contour, PixelBox& box) const;
  // The ball-coloured pixels in the box: count, sums for the centroid, nearest and farthest
  // radius from the mirror centre.
  struct BallPixels {
    double sum_u = 0, sum_v = 0;
    double near_radius = 0, far_radius = 0;
    int count = 0;
  };
  BallPixels ballPixels(const camera::FrameView& frame, const PixelBox& box) const;
  // Where the ball's centre is (robot frame and image) from the pixels' radii and centroid, and
  // whether the field (with a region) allows a ball there.
  struct BallPlace {
    camera::Vec2 centroid;
    double bearing = 0;
    double horizontal = 0;  // floor distance of the centre from the mirror axis, m
    double lift = 0;        // (reference height - centre height) / reference height
    camera::Vec2 centre_xy;
    camera::Vec2 centre_pixel;
    // The far edge was cut by the useful radius: the centre comes from the near edge alone.
    bool far_edge_cut = false;
  };
  BallReject place(const BallPixels& pixels, const BallRegion* region, bool yuyv,
                   BallPlace& out) const;
  // The depression angle (from the reference point R, rad) of the ray to the ball's centre, from
  // the outermost pixels' radii moved out to the silhouette's edges by `insets`; with `farCut`,
  // from the near edge alone.
  double centreAngle(const BallPixels& pixels, double bearing, const EdgeInsets& insets,
                     bool farCut) const;
  // Size and shape against a ball at that place.
  struct BallShape {
    double expected_radial = 0, expected_tangential = 0;
    double radial_px = 0, tangential_px = 0;
    double fill = 0;
  };
  BallReject checkShape(const camera::FrameView& frame, const PixelBox& box,
                        const BallPixels& pixels, const BallPlace& place, BallShape& out) const;
  // The share of carpet on a ring around the candidate; false where too few samples of the
  // ring see the floor or too few of them are carpet.
  bool onCarpet(const camera::FrameView& frame, const camera::Vec2& centroid,
                const BallShape& shape, double& carpetShare) const;

  const camera::ColourTable& table_;
  const camera::MirrorModel& mirror_;
  BallParams params_;
  // Regions whose bounding box is larger than this (px) are no ball anywhere in the image.
  double max_extent_px_ = 0;
  bool has_colour_ = false;
  // edgeInsets()'s table (shared: edgeInsetTableFor).
  std::shared_ptr<const EdgeInsetTable> insets_;
};

}  // namespace fieldline::region_tracking
