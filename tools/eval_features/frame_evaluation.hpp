// The parts of fieldline-eval-features' evaluation (eval_features.hpp): the scene of each frame,
// the evaluation of a frame's hypotheses against the truth, the diagnosis of missed corners, and
// the pipeline of camera, region tracker and recogniser.
#pragma once

#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/field_features.hpp"
#include "common/perception/line_points.hpp"
#include "services/feature_recognition/recognizer.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/eval_features/eval_features.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::eval_features {

inline constexpr double kPi = std::numbers::pi;

using geometry::Pose2;
using geometry::Vec2;
using perception::FeatureKind;

// A hypothesis further than this from every symmetric image of the true pose is false.
inline constexpr double kFalseDistance = 0.5;
inline constexpr double kFalseAngle = 10.0 * std::numbers::pi / 180.0;
// Features count as "in view" within this distance (the targets).
inline constexpr double kViewDistance = 4.0;

// --- the scene (scene.cpp) ---

// The eight penalty-area corners: (inner, left) as seen toward their goal, and the goal.
struct CornerSite {
  Vec2 position;
  bool inner;
  bool left;
  bool opponent_goal;
};

std::vector<CornerSite> cornerSites(const field::FieldModel& field);

// Kinds of the detection maps (seed fig. 4.59).
enum MapKind { kCircle, kLeftOuter, kRightOuter, kLeftInner, kRightInner, kMapKinds };
inline const char* const kMapNames[kMapKinds] = {"centre_circle", "left_outer_corner",
                                                 "right_outer_corner", "left_inner_corner",
                                                 "right_inner_corner"};

struct FrameRecord {
  Vec2 position;
  bool detected[kMapKinds] = {};
  bool false_hypothesis = false;
};

// A path scanning the field in lanes along x (the carpet up to 0.5 m beyond the lines), the
// robot turning steadily so that every place is seen under many headings.
std::vector<Pose2> scanPath(const field::FieldModel& field, int frames);
// Per-frame random numbers: frame f of seed s is the same whatever frames ran before it.
std::mt19937 frameRng(std::uint32_t seed, std::uint64_t frame, std::uint32_t stream);
// The robot's scene in frame `frame`: opponents within 1-5 m (some white, some of a third team's
// colour), white objects beyond the border lines, people beyond the side lines, flat white
// patches on the carpet and orange objects. Deterministic per (seed, frame).
camera::SimScene sceneFor(const Pose2& pose, std::uint64_t frame, const Options& o,
                          const field::FieldModel& field);

// --- one frame (frame_evaluation.cpp) ---

// Position and heading error of `h` against the nearer of the true pose and its twin.
void errorsAgainst(const Pose2& truth, const Pose2& h, double& position, double& heading);
// The frame's line points from the region tracker, which starts afresh on the frame.
void visionOf(region_tracking::SimCamera& sim, region_tracking::FrameProcessor& processor,
              const camera::SimScene& scene, region_tracking::VisionResult& vision);

struct FrameResult {
  FrameRecord record;
  int hypotheses = 0;
  int false_hypotheses = 0;
  bool circle_eligible = false;
  bool circle_found = false;
  int corner_eligible = 0;
  int corner_found = 0;
  std::vector<double> position_errors, heading_errors;
  // Corners within 4 m: site index, distance, found.
  struct Eligible {
    int site;
    double distance;
    bool found;
  };
  std::vector<Eligible> eligible_corners;
};

FrameResult evaluate(const Pose2& pose, const perception::FieldFeatures& features,
                     const std::vector<CornerSite>& sites, double circle_radius);

// The recogniser's and the region tracker's parameters from the options.
feature_recognition::RecognitionParams recognitionParamsOf(const Options& options);
region_tracking::VisionParams visionParamsOf(const Options& options);

// Camera, region tracking and recogniser of one evaluation (kept at one address: the processor
// and the recogniser refer to the camera's models).
struct Pipeline {
  region_tracking::SimCamera sim;
  feature_recognition::FeatureRecognizer recognizer;
  region_tracking::FrameProcessor processor;
  explicit Pipeline(const Options& options)
      : sim(region_tracking::SimCamera::load(options.camera, options.field)),
        recognizer(sim.field, recognitionParamsOf(options)),
        processor(sim.mirror, sim.table, visionParamsOf(options)) {}
};

// True if frame `frame` at `pose`, evaluated by a freshly built pipeline, gives the same line
// points and hypotheses as `vision` and `features` (from the running one); prints the
// difference otherwise.
bool sameAsFresh(const Options& options, const Pose2& pose, std::uint64_t frame,
                 const region_tracking::VisionResult& vision,
                 const perception::FieldFeatures& features);

// One frame in detail (--frame, --pose): its hypotheses, the model check's verdicts, the line
// groups and pieces, the corners within 4 m; optionally the camera image with the line points and
// the points as CSV. Returns the exit code.
int detailFrame(const Options& options, region_tracking::SimCamera& sim,
                region_tracking::FrameProcessor& processor,
                feature_recognition::FeatureRecognizer& recognizer, const Pose2& pose,
                std::uint64_t frame);

// --- what the camera could see, why a corner was missed (misses.cpp) ---

// True if the ray from the camera (at the mirror's reference height above the robot) to the floor
// point `q` (field frame) passes through a robot's cylinder.
bool rayBlocked(const camera::SimScene& scene, const Vec2& q, double camera_height,
                double robot_height);
// Share of the centre circle hidden from the camera by the robots in `scene`.
double occludedCircleShare(const camera::SimScene& scene, double radius, double camera_height,
                           double robot_height);

// Why a penalty corner within 4 m was not found (--misses-csv): what the camera could see of it,
// how many line points lie on its two lines near it, and how far the recogniser's stages got.
struct MissDiagnosis {
  // Where the corner point appears: 0 useful, 1 inside the robot's own reflection, 2 beyond the
  // useful radius or outside the image; and whether an opponent stands in the ray to it.
  int zone = 0;
  bool blocked = false;
  // Share of samples (every 5 cm over the first `kLegReach` of each line from the corner) that
  // are in the useful zone and not blocked.
  double front_visible = 0.0, side_visible = 0.0;
  // Line points within 0.12 m of those two leg pieces, 0.1 m or more from their ends.
  int front_points = 0, side_points = 0;
  // A line group of the structure along each leg (within 0.2 m and 0.3 rad, reaching within
  // 0.5 m of the corner).
  bool front_group = false, side_group = false;
  // An L-corner (or T) of the recogniser within 0.4 m; a stage-5 corner within 0.4 m; a model
  // check verdict on a penalty corner within 0.4 m (and whether it was accepted).
  bool junction = false;
  bool structure_corner = false;
  bool checked = false;
  std::string cause;
};

// The visibility part of the diagnosis (zone, blocked, front_visible, side_visible).
void cornerVisibility(const CornerSite& site, const Pose2& pose, const camera::SimScene& scene,
                      const region_tracking::SimCamera& sim, MissDiagnosis& m);
// A corner the camera can see: its point in the useful part of the image, no robot in the way,
// and at least half of the first 0.75 m of both its lines visible likewise.
bool seeable(const MissDiagnosis& m);
MissDiagnosis diagnoseMiss(const CornerSite& site, const Pose2& pose, const camera::SimScene& scene,
                           const region_tracking::SimCamera& sim,
                           const perception::LinePoints& lines,
                           const feature_recognition::FeatureRecognizer& recognizer);
// Seed fig. 4.60: the centre circle detection rate per occluded share (--occlusion-frames).
void occlusionSeries(const Options& options, region_tracking::SimCamera& sim,
                     region_tracking::FrameProcessor& processor,
                     feature_recognition::FeatureRecognizer& recognizer);

}  // namespace fieldline::eval_features
