// fieldline-eval-features: renders frames at poses over the whole field (a scanning path with
// the robot turning through all headings, opponents and clutter around it), runs the region
// tracker and the feature recogniser on each, and compares every pose hypothesis with the true
// pose and its point-symmetric twin. Writes detection maps per feature kind (seed fig. 4.59), an
// occlusion series of the centre circle (fig. 4.60) and a JSON summary, and ends with
//   frames=N false_hypotheses=F circle_rate=A corner_rate=B pos_median_m=P heading_median_deg=H
//
//   fieldline-eval-features --frames 3000 --out build/eval_features
//   fieldline-eval-features --frames 3000 --frame 318 --image f318.png --dump f318.csv
//   fieldline-eval-features --pose 1,0.5,0.3 --dump points.csv     (one frame's line points)
//
// Every frame is reproducible on its own: its clutter comes from (seed, frame), the sensor noise
// from the frame number, and the region tracker starts afresh on each frame.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/camera/image_io.hpp"
#include "common/geometry/geometry.hpp"
#include "common/perception/line_points_csv.hpp"
#include "services/feature_recognition/recognizer.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace {

using namespace fieldline;
using geometry::Pose2;
using geometry::Vec2;
using perception::FeatureKind;

constexpr double kPi = std::numbers::pi;
// A hypothesis further than this from every symmetric image of the true pose is false.
constexpr double kFalseDistance = 0.5;
constexpr double kFalseAngle = 10.0 * kPi / 180.0;
// Features count as "in view" within this distance (the targets).
constexpr double kViewDistance = 4.0;

struct Options {
  int frames = 3000;
  std::string field = "msl";
  std::string camera = "omni_sim";
  // The region tracker's line sample spacing (px); 0 = its default (vision_default.yaml).
  int sample_spacing = 0;
  // Sampling by distance on the field (m; 0 = off; negative = the default of
  // vision_default.yaml, or off when sample_spacing is given), and its minimum pixel spacing
  // (0 = the default).
  double sample_spacing_m = -1.0;
  double sample_min_px = 0.0;
  // Denser near the contour's turns (m; negative = the default), and the reach (m; negative =
  // the default).
  double turn_spacing_m = -1.0;
  double turn_reach_m = -1.0;
  double turn_range_m = -1.0;
  // The line detector's refinement (sampling by index; negative = the default's).
  double refine_range_m = -1.0, refine_min_range_m = -1.0, refine_turn = -1.0,
         refine_spacing_m = -1.0;
  int refine_samples = 0, refine_reach = 0;
  bool refine_isolated = false;
  // The recogniser's line_end_alone_side_points (negative = its default).
  int alone_side_points = -1;
  // The recogniser's line_end_max_beyond_points (below -1 = its default) and
  // model_check_goal_shadow (0 off, 1 on, -1 its default).
  int max_beyond_points = -2;
  int goal_shadow = -1;
  // The recogniser's identity_max_beyond_points (below -1 = its default).
  int identity_max_beyond = -2;
  double identity_beyond_reach = -1.0;
  double beyond_from = -1.0;
  // The recogniser's unseen_max_stretch and unseen_range (below -1 / 0: its defaults).
  double max_unseen = -2.0;
  double unseen_range = 0.0;
  // The recogniser's consistency_veto_margin (below -1: its default).
  double veto_margin = -2.0;
  // Frames to run from first_frame (0 = to the end of the path).
  int count = 0;
  // Every this many frames, the frame is also evaluated by a freshly built pipeline (camera,
  // region tracker, recogniser) and must give the same line points and hypotheses (0 = never).
  int check_fresh_every = 0;
  bool clutter = true;
  int opponents = 3;
  // Clutter knobs (with --no-clutter all are off).
  double white_robot_share = 0.3;   // opponents with a white body
  double other_colour_share = 0.3;  // opponents with a marker of a third team's colour
  int white_objects = 2;            // white boxes beyond the field's border lines
  int people = 2;                   // people standing beyond the side lines
  int patches = 2;                  // flat white patches on the carpet within 5 m
  int orange_objects = 1;           // a ball within 5 m, an orange box beyond the border
  std::uint32_t seed = 1;
  std::string out_dir;
  double min_circle_rate = -1.0;
  double min_corner_rate = -1.0;
  int occlusion_frames = 0;
  std::string pose;
  int frame = -1;
  // Only the frames from this one on of the --frames path (to look into a part of a long run).
  int first_frame = 0;
  std::string image;
  std::string dump;
  bool progress = false;
  std::string check_csv;
  std::string misses_csv;
  std::string circle_misses_csv;
};

// The eight penalty-area corners: (inner, left) as seen toward their goal, and the goal.
struct CornerSite {
  Vec2 position;
  bool inner;
  bool left;
  bool opponent_goal;
};

std::vector<CornerSite> cornerSites(const field::FieldModel& field) {
  const auto& d = field.dimensions();
  std::vector<CornerSite> sites;
  for (int inner = 0; inner < 2; ++inner) {
    for (int left = 0; left < 2; ++left) {
      const double x = field.length() / 2 - (inner ? d.goal_area_depth : d.penalty_area_depth);
      const double y = (inner ? d.goal_area_width : d.penalty_area_width) / 2 * (left ? 1 : -1);
      sites.push_back({Vec2(x, y), inner != 0, left != 0, true});
      sites.push_back({Vec2(-x, -y), inner != 0, left != 0, false});
    }
  }
  return sites;
}

// Kinds of the detection maps (seed fig. 4.59).
enum MapKind { kCircle, kLeftOuter, kRightOuter, kLeftInner, kRightInner, kMapKinds };
const char* const kMapNames[kMapKinds] = {"centre_circle", "left_outer_corner",
                                          "right_outer_corner", "left_inner_corner",
                                          "right_inner_corner"};

struct FrameRecord {
  Vec2 position;
  bool detected[kMapKinds] = {};
  bool false_hypothesis = false;
};

// A path scanning the field in lanes along x (the carpet up to 0.5 m beyond the lines), the
// robot turning steadily so that every place is seen under many headings.
std::vector<Pose2> scanPath(const field::FieldModel& field, int frames) {
  const double half_x = field.length() / 2 + 0.5, half_y = field.width() / 2 + 0.5;
  const double lane = 0.8;
  std::vector<Vec2> corners;
  int k = 0;
  for (double y = -half_y; y <= half_y + 1e-9; y += lane, ++k) {
    corners.emplace_back(k % 2 ? half_x : -half_x, y);
    corners.emplace_back(k % 2 ? -half_x : half_x, y);
  }
  double total = 0.0;
  for (std::size_t i = 1; i < corners.size(); ++i)
    total += (corners[i] - corners[i - 1]).norm();
  std::vector<Pose2> poses;
  std::size_t segment = 1;
  double segment_start = 0.0;
  for (int f = 0; f < frames; ++f) {
    const double s = total * f / std::max(frames, 1);
    while (segment + 1 < corners.size() &&
           segment_start + (corners[segment] - corners[segment - 1]).norm() < s) {
      segment_start += (corners[segment] - corners[segment - 1]).norm();
      ++segment;
    }
    const Vec2 a = corners[segment - 1], b = corners[segment];
    const double t = std::clamp((s - segment_start) / std::max((b - a).norm(), 1e-9), 0.0, 1.0);
    const Vec2 p = a + t * (b - a);
    poses.push_back({p.x(), p.y(), geometry::normalizeAngle(0.37 * f)});
  }
  return poses;
}

// Per-frame random numbers: frame f of seed s is the same whatever frames ran before it.
std::mt19937 frameRng(std::uint32_t seed, std::uint64_t frame, std::uint32_t stream) {
  std::seed_seq seq{seed, static_cast<std::uint32_t>(frame),
                    static_cast<std::uint32_t>(frame >> 32), stream};
  return std::mt19937(seq);
}

const camera::Bgr kWhite{225, 230, 230};
const camera::Bgr kOrange{10, 100, 240};
// Third-team markers and clothes: red, blue, yellow, dark grey, a light shirt.
const camera::Bgr kColours[] = {
    {40, 40, 200}, {200, 90, 30}, {30, 200, 220}, {60, 60, 60}, {200, 205, 205}};

// The robot's scene in frame `frame`: opponents within 1-5 m (some white, some of a third team's
// colour), white objects beyond the border lines, people beyond the side lines, flat white
// patches on the carpet and orange objects. Deterministic per (seed, frame).
camera::SimScene sceneFor(const Pose2& pose, std::uint64_t frame, const Options& o,
                          const field::FieldModel& field) {
  camera::SimScene scene;
  scene.robot = pose;
  scene.frame_number = frame;
  if (!o.clutter) return scene;
  std::mt19937 rng = frameRng(o.seed, frame, 0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const Vec2 half = field.carpetHalfExtent();
  for (int i = 0; i < o.opponents; ++i) {
    const double d = uniform(1.0, 5.0), b = uniform(-kPi, kPi);
    const Vec2 p = pose.position() + d * Vec2(std::cos(b), std::sin(b));
    const double kind = unit(rng);
    const camera::Bgr colour = kColours[static_cast<int>(unit(rng) * 4.999)];
    if (std::abs(p.x()) > half.x() - 0.3 || std::abs(p.y()) > half.y() - 0.3) continue;
    camera::SimRobot r{p, 0.25, false, {}, {}};
    if (kind < o.white_robot_share) {
      r.body_colour = kWhite;
    } else if (kind < o.white_robot_share + o.other_colour_share) {
      r.marker_colour = colour;
    }
    scene.robots.push_back(r);
  }
  using region_tracking::standingBox;
  // Where hall clutter stands: beyond the field's lines.
  auto beyondBorder = [&](bool side_only) {
    return region_tracking::placeBeyondLines(field, rng, side_only);
  };
  for (int i = 0; i < o.white_objects; ++i) {
    const Vec2 c = beyondBorder(false);
    const double sx = uniform(0.2, 1.0), sy = uniform(0.2, 1.0), h = uniform(0.2, 1.2);
    scene.boxes.push_back(standingBox(c, sx, sy, h, kWhite));
  }
  for (int i = 0; i < o.people; ++i) {
    const Vec2 c = beyondBorder(true);
    const camera::Bgr colour = kColours[static_cast<int>(unit(rng) * 4.999)];
    scene.boxes.push_back(standingBox(c, 0.45, 0.3, uniform(1.5, 1.9), colour));
  }
  for (int i = 0; i < o.patches; ++i) {
    const double d = uniform(0.8, 5.0), b = uniform(-kPi, kPi);
    const Vec2 c = pose.position() + d * Vec2(std::cos(b), std::sin(b));
    scene.boxes.push_back(standingBox(c, uniform(0.05, 0.3), uniform(0.05, 0.3), 0.004, kWhite));
  }
  for (int i = 0; i < o.orange_objects; ++i) {
    const double d = uniform(0.8, 5.0), b = uniform(-kPi, kPi);
    scene.ball = camera::SimBall{pose.position() + d * Vec2(std::cos(b), std::sin(b)), 0.11};
    scene.boxes.push_back(standingBox(beyondBorder(false), uniform(0.2, 0.6), uniform(0.2, 0.6),
                                      uniform(0.1, 0.8), kOrange));
  }
  return scene;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Position and heading error of `h` against the nearer of the true pose and its twin.
void errorsAgainst(const Pose2& truth, const Pose2& h, double& position, double& heading) {
  const Pose2 twin{-truth.x, -truth.y, geometry::normalizeAngle(truth.phi + kPi)};
  const double e1 = (h.position() - truth.position()).norm();
  const double e2 = (h.position() - twin.position()).norm();
  const Pose2& near = e1 <= e2 ? truth : twin;
  position = std::min(e1, e2);
  heading = std::abs(geometry::angleDiff(h.phi, near.phi));
}

// Draws the field's lines thinly into an image, field +x right, +y up.
struct MapCanvas {
  double scale;
  Vec2 half;
  cv::Mat image;
  MapCanvas(const field::FieldModel& field, double px_per_m) : scale(px_per_m) {
    half = field.carpetHalfExtent();
    image = cv::Mat(static_cast<int>(2 * half.y() * scale), static_cast<int>(2 * half.x() * scale),
                    CV_8UC3, cv::Scalar(40, 110, 40));
    for (const auto& s : field.segments()) {
      cv::line(image, px(s.a), px(s.b), cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
    }
    for (const auto& arc : field.arcs()) {
      const int steps = 64;
      for (int i = 0; i < steps; ++i) {
        const Vec2 p0 = arc.pointAt(arc.start_angle + arc.sweep * i / steps);
        const Vec2 p1 = arc.pointAt(arc.start_angle + arc.sweep * (i + 1) / steps);
        cv::line(image, px(p0), px(p1), cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
      }
    }
  }
  cv::Point px(const Vec2& p) const {
    return {static_cast<int>(std::lround((p.x() + half.x()) * scale)),
            static_cast<int>(std::lround((half.y() - p.y()) * scale))};
  }
};

// The frame's line points from the region tracker, independent of earlier frames: the tracker
// starts afresh and tracks the frame twice (the first pass finds the regions, the second
// follows them as in a running camera). Afresh means as built, not only reinitialised: the
// tracker's frame counter sets the phases of its interleaved work (the mask-edge cells every
// 2nd frame, the view-edge seeds every 4th cell, the search inside the parent every 16 frames)
// and a class's frames_lost outlives reinitialise(), so a reinitialised tracker tracked frame K
// differently depending on the frame the run started at (frame 87411 of 100,000 frames gave a
// false hypothesis in the whole run, not with --first-frame 87411).
void visionOf(region_tracking::SimCamera& sim, region_tracking::FrameProcessor& processor,
              const camera::SimScene& scene, region_tracking::VisionResult& vision) {
  const camera::FrameView view = sim.render(scene);
  region_tracking::RegionTracker& tracker = processor.tracker();
  tracker =
      region_tracking::RegionTracker(processor.grid(), tracker.config(), processor.dontTouch());
  processor.process(view, true, vision);
  processor.process(view, true, vision);
}

// What one frame showed.
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
                     const std::vector<CornerSite>& sites, double circle_radius) {
  FrameResult r;
  r.record.position = pose.position();
  bool correct_circle = false;
  for (const auto& h : features.hypotheses) {
    ++r.hypotheses;
    double position = 0, heading = 0;
    errorsAgainst(pose, h.pose, position, heading);
    if (position > kFalseDistance || heading > kFalseAngle) {
      ++r.false_hypotheses;
      r.record.false_hypothesis = true;
      continue;
    }
    r.position_errors.push_back(position);
    r.heading_errors.push_back(heading * 180 / kPi);
    if (features.features[h.feature].kind == FeatureKind::kCentreCircle) correct_circle = true;
  }
  r.record.detected[kCircle] = correct_circle;
  r.circle_eligible = pose.position().norm() + circle_radius <= kViewDistance;
  r.circle_found = r.circle_eligible && correct_circle;
  for (const CornerSite& site : sites) {
    bool found = false;
    for (const auto& feature : features.features) {
      if (feature.kind != FeatureKind::kPenaltyCorner) continue;
      const Vec2 seen = geometry::pointRobotToField(pose, {feature.local.x, feature.local.y});
      if ((seen - site.position).norm() <= kFalseDistance) found = true;
    }
    if (found) {
      r.record.detected[site.inner ? (site.left ? kLeftInner : kRightInner)
                                   : (site.left ? kLeftOuter : kRightOuter)] = true;
    }
    const double distance = (site.position - pose.position()).norm();
    if (distance <= kViewDistance) {
      ++r.corner_eligible;
      if (found) ++r.corner_found;
      r.eligible_corners.push_back({static_cast<int>(&site - sites.data()), distance, found});
    }
  }
  return r;
}

// One frame in detail: its hypotheses, the model check's verdicts, the line groups and pieces,
// the corners within 4 m; optionally the camera image with the line points and the points as CSV.
int detailFrame(const Options& options, region_tracking::SimCamera& sim,
                region_tracking::FrameProcessor& processor,
                feature_recognition::FeatureRecognizer& recognizer, const Pose2& pose,
                std::uint64_t frame) {
  region_tracking::VisionResult vision;
  perception::FieldFeatures features;
  const camera::SimScene scene = sceneFor(pose, frame, options, sim.field);
  visionOf(sim, processor, scene, vision);
  if (!options.dump.empty()) {
    std::ofstream out(options.dump);
    perception::writeLinePointsCsv(out, vision.lines);
  }
  if (!options.image.empty()) {
    cv::Mat image = camera::toBgrImage(sim.renderer->view(sim.frame));
    for (std::size_t s = 0; s < vision.lines.sequences.size(); ++s) {
      const auto [begin, end] = vision.lines.sequences[s];
      const cv::Scalar colour = s % 2 ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 0, 255);
      for (int i = begin; i < end; ++i) {
        const auto& p = vision.lines.points[static_cast<std::size_t>(i)];
        cv::circle(image, {static_cast<int>(p.u), static_cast<int>(p.v)}, 1, colour, -1);
      }
    }
    camera::writeImage(options.image, image);
  }
  recognizer.recognize(vision.lines, features);
  std::cout << "frame=" << frame << " pose=" << pose.x << "," << pose.y << "," << pose.phi
            << " robots=" << scene.robots.size() << " boxes=" << scene.boxes.size() << "\n";
  for (const auto& h : features.hypotheses) {
    double position = 0, heading = 0;
    errorsAgainst(pose, h.pose, position, heading);
    std::cout << "hypothesis kind=" << static_cast<int>(features.features[h.feature].kind)
              << " pose=" << h.pose.x << "," << h.pose.y << "," << h.pose.phi
              << " error_m=" << position << " error_deg=" << heading * 180 / kPi << "\n";
  }
  for (const auto& c : recognizer.checked()) {
    double position = 0, heading = 0;
    errorsAgainst(pose, c.robot, position, heading);
    std::cout << "model_check kind=" << static_cast<int>(c.kind) << " local=" << c.local.x << ","
              << c.local.y << "," << c.local.phi << " share=" << c.fit.share()
              << " points=" << c.fit.points << " others_share=" << c.others.share()
              << " others=" << c.others.points << " rival=" << c.rival_share
              << " shifted=" << c.shifted_share << " side_points=" << c.side_points
              << " beyond_points=" << c.beyond_points << " unseen=" << c.unseen
              << " accepted=" << c.accepted << " error_m=" << position << "\n";
  }
  for (const CornerSite& site : cornerSites(sim.field)) {
    const double d = (site.position - pose.position()).norm();
    if (d > kViewDistance) continue;
    const Vec2 local = geometry::pointFieldToRobot(pose, site.position);
    std::cout << "corner_within_4m inner=" << site.inner << " left=" << site.left
              << " opponent_goal=" << site.opponent_goal << " distance=" << d
              << " local=" << local.transpose() << "\n";
  }
  const auto& structure = recognizer.structure();
  for (int a = 0; a < 2; ++a) {
    for (const auto& g : structure.groups[a]) {
      std::cout << "group axis=" << a << " t=" << g.t << " length=" << g.line.length()
                << " rms=" << g.line.rms << " n=" << g.line.count
                << " start=" << g.line.start().transpose() << " end=" << g.line.end().transpose()
                << "\n";
    }
  }
  const auto& contours = recognizer.contours();
  for (const auto& piece : contours.pieces) {
    const Vec2* p = contours.points.data() + piece.begin;
    const auto line = feature_recognition::fitLine(p, piece.size());
    std::cout << "piece n=" << piece.size()
              << " turn=" << feature_recognition::pieceTurn(p, piece.size()) << " rms=" << line.rms
              << " length=" << line.length() << " from=" << p[0].transpose()
              << " to=" << p[piece.size() - 1].transpose() << "\n";
  }
  std::cout << "pieces=" << contours.pieces.size()
            << " lines=" << recognizer.classified().lines.size()
            << " arcs=" << recognizer.classified().arcs.size()
            << " penalty=" << recognizer.penaltyFound()
            << " corners=" << recognizer.penalty().corners.size()
            << " points=" << vision.lines.points.size()
            << " sequences=" << vision.lines.sequences.size()
            << " features=" << features.features.size() << "\n";
  return 0;
}

// True if the ray from the camera (at the mirror's reference height above the robot) to the floor
// point `q` (field frame) passes through a robot's cylinder.
bool rayBlocked(const camera::SimScene& scene, const Vec2& q, double camera_height,
                double robot_height) {
  const Vec2 p = scene.robot.position();
  const Vec2 d = q - p;
  for (const auto& robot : scene.robots) {
    // |p + t d - c| = rho for t in [t0, t1]; the ray is below the robot's top for
    // t >= 1 - robot_height / camera_height.
    const Vec2 f = p - robot.position;
    const double A = d.squaredNorm(), B = 2 * f.dot(d),
                 C = f.squaredNorm() - robot.radius * robot.radius;
    const double disc = B * B - 4 * A * C;
    if (disc < 0 || A <= 0) continue;
    const double t0 = (-B - std::sqrt(disc)) / (2 * A), t1 = (-B + std::sqrt(disc)) / (2 * A);
    const double low = std::max(t0, 1.0 - robot_height / camera_height);
    if (t1 >= low && low <= 1.0 && t1 >= 0.0) return true;
  }
  return false;
}

// Share of the centre circle hidden from the camera by the robots in `scene`: the circle sampled
// every degree, a sample hidden when the ray from the camera to it is blocked.
double occludedCircleShare(const camera::SimScene& scene, double radius, double camera_height,
                           double robot_height) {
  const int samples = 360;
  int hidden = 0;
  for (int k = 0; k < samples; ++k) {
    const double a = 2 * kPi * k / samples;
    if (rayBlocked(scene, radius * Vec2(std::cos(a), std::sin(a)), camera_height, robot_height)) {
      ++hidden;
    }
  }
  return static_cast<double>(hidden) / samples;
}

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

constexpr double kLegReach = 0.75;

// The visibility part of the diagnosis (zone, blocked, front_visible, side_visible).
void cornerVisibility(const CornerSite& site, const Pose2& pose, const camera::SimScene& scene,
                      const region_tracking::SimCamera& sim, MissDiagnosis& m) {
  const auto& d = sim.field.dimensions();
  const double camera_height = sim.mirror.params().reference_height;
  const double robot_height = sim.renderer->params().robot_height;
  const Vec2 corner = site.position;
  const double sx = corner.x() > 0 ? 1.0 : -1.0, sy = corner.y() > 0 ? 1.0 : -1.0;
  const Vec2 front_dir(0.0, -sy), side_dir(sx, 0.0);
  const double side_length =
      std::min(kLegReach, site.inner ? d.goal_area_depth : d.penalty_area_depth);
  auto zoneOf = [&](const Vec2& field_point) {
    const Vec2 local = geometry::pointFieldToRobot(pose, field_point);
    const auto pixel = sim.mirror.robotToImage(local);
    if (!pixel) return local.norm() < 1.0 ? 1 : 2;
    const camera::MirrorZone z = sim.mirror.zone(*pixel);
    return z == camera::MirrorZone::kUseful ? 0 : z == camera::MirrorZone::kSelf ? 1 : 2;
  };
  m.zone = zoneOf(corner);
  m.blocked = rayBlocked(scene, corner, camera_height, robot_height);
  auto visibleShare = [&](const Vec2& dir, double length) {
    int seen = 0, n = 0;
    for (double t = 0.05; t <= length + 1e-9; t += 0.05, ++n) {
      const Vec2 q = corner + t * dir;
      if (zoneOf(q) == 0 && !rayBlocked(scene, q, camera_height, robot_height)) ++seen;
    }
    return n ? static_cast<double>(seen) / n : 0.0;
  };
  m.front_visible = visibleShare(front_dir, kLegReach);
  m.side_visible = visibleShare(side_dir, side_length);
}

// A corner the camera can see: its point in the useful part of the image, no robot in the way,
// and at least half of the first 0.75 m of both its lines visible likewise.
bool seeable(const MissDiagnosis& m) {
  return m.zone == 0 && !m.blocked && m.front_visible >= 0.5 && m.side_visible >= 0.5;
}

MissDiagnosis diagnoseMiss(const CornerSite& site, const Pose2& pose, const camera::SimScene& scene,
                           const region_tracking::SimCamera& sim,
                           const perception::LinePoints& lines,
                           const feature_recognition::FeatureRecognizer& recognizer) {
  MissDiagnosis m;
  cornerVisibility(site, pose, scene, sim, m);
  const auto& d = sim.field.dimensions();
  const Vec2 corner = site.position;
  const double sx = corner.x() > 0 ? 1.0 : -1.0, sy = corner.y() > 0 ? 1.0 : -1.0;
  const Vec2 front_dir(0.0, -sy), side_dir(sx, 0.0);
  const double side_length =
      std::min(kLegReach, site.inner ? d.goal_area_depth : d.penalty_area_depth);
  const Vec2 local_corner = geometry::pointFieldToRobot(pose, corner);
  const Vec2 local_front = geometry::rotate(front_dir, -pose.phi);
  const Vec2 local_side = geometry::rotate(side_dir, -pose.phi);
  auto onLeg = [&](const Vec2& p, const Vec2& dir, double length) {
    // Away from both ends (the points of the perpendicular lines there are not the leg's).
    const double t = (p - local_corner).dot(dir);
    if (t < 0.1 || t > length - 0.1) return false;
    return (p - local_corner - t * dir).norm() <= 0.12;
  };
  for (const auto& p : lines.points) {
    const Vec2 q(p.x, p.y);
    if (onLeg(q, local_front, kLegReach)) ++m.front_points;
    if (onLeg(q, local_side, side_length)) ++m.side_points;
  }
  const auto& structure = recognizer.structure();
  for (const auto& groups : structure.groups) {
    for (const auto& g : groups) {
      const auto& line = g.line;
      auto along = [&](const Vec2& dir) {
        if (std::abs(line.direction.dot(dir)) < std::cos(0.3)) return false;
        if (std::abs(line.signedDistance(local_corner)) > 0.2) return false;
        // The group's extent reaches within 0.5 m of the corner on the leg's side.
        const double a = (line.start() - local_corner).dot(dir);
        const double b = (line.end() - local_corner).dot(dir);
        return std::max(a, b) > 0.1 && std::min(a, b) < 0.5;
      };
      if (along(local_front)) m.front_group = true;
      if (along(local_side)) m.side_group = true;
    }
  }
  for (const auto& j : recognizer.junctions()) {
    if ((j.position - local_corner).norm() <= 0.4) m.junction = true;
  }
  if (recognizer.penaltyFound()) {
    for (const auto& c : recognizer.penalty().corners) {
      if ((c.position - local_corner).norm() <= 0.4) m.structure_corner = true;
    }
  }
  for (const auto& c : recognizer.checked()) {
    if (c.kind != FeatureKind::kPenaltyCorner) continue;
    if ((Vec2(c.local.x, c.local.y) - local_corner).norm() <= 0.4) m.checked = true;
  }
  const int min_points = recognizer.params().min_corner_line_points;
  if (m.zone == 1) {
    m.cause = "self_reflection";
  } else if (m.zone == 2) {
    m.cause = "beyond_view";
  } else if (m.blocked) {
    m.cause = "occluded";
  } else if (m.front_visible < 0.5 || m.side_visible < 0.5) {
    m.cause = "leg_hidden";
  } else if (m.front_points < min_points || m.side_points < min_points) {
    m.cause = "few_points";
  } else if (!m.front_group || !m.side_group) {
    m.cause = "no_line_group";
  } else if (!m.junction && !m.structure_corner) {
    m.cause = "no_junction";
  } else if (m.checked) {
    m.cause = "refused";
  } else {
    m.cause = "not_identified";
  }
  return m;
}

// Seed fig. 4.60: the robot within reach of the whole centre circle, 0-10 robots standing on and
// around the circle; the centre circle detection rate per occluded share (bins of 10 %).
void occlusionSeries(const Options& options, region_tracking::SimCamera& sim,
                     region_tracking::FrameProcessor& processor,
                     feature_recognition::FeatureRecognizer& recognizer) {
  const double radius = sim.field.dimensions().centre_circle_radius;
  const double camera_height = sim.mirror.params().reference_height;
  const double robot_height = sim.renderer->params().robot_height;
  constexpr int kBins = 10;
  long frames[kBins] = {}, found[kBins] = {};
  long false_hypotheses = 0;
  region_tracking::VisionResult vision;
  perception::FieldFeatures features;
  for (int f = 0; f < options.occlusion_frames; ++f) {
    std::mt19937 rng = frameRng(options.seed, static_cast<std::uint64_t>(f), 1);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double reach = std::max(0.0, kViewDistance - radius);
    const double rr = reach * std::sqrt(unit(rng)), ra = 2 * kPi * unit(rng);
    camera::SimScene scene;
    scene.robot = {rr * std::cos(ra), rr * std::sin(ra), 2 * kPi * unit(rng) - kPi};
    scene.frame_number = 1'000'000'000ULL + static_cast<std::uint64_t>(f);
    const int obstacles = static_cast<int>(unit(rng) * 11);
    for (int i = 0; i < obstacles; ++i) {
      const double a = 2 * kPi * unit(rng);
      const Vec2 c = (radius + 1.0 * (unit(rng) - 0.5)) * Vec2(std::cos(a), std::sin(a));
      if ((c - scene.robot.position()).norm() < 0.8) continue;
      scene.robots.push_back({c, 0.25, false, {}, {}});
    }
    const double share = occludedCircleShare(scene, radius, camera_height, robot_height);
    visionOf(sim, processor, scene, vision);
    recognizer.recognize(vision.lines, features);
    bool correct = false;
    for (const auto& h : features.hypotheses) {
      double position = 0, heading = 0;
      errorsAgainst(scene.robot, h.pose, position, heading);
      if (position > kFalseDistance || heading > kFalseAngle) {
        ++false_hypotheses;
      } else if (features.features[h.feature].kind == FeatureKind::kCentreCircle) {
        correct = true;
      }
    }
    const int bin = std::min(kBins - 1, static_cast<int>(share * kBins));
    ++frames[bin];
    if (correct) ++found[bin];
  }
  std::ostringstream json;
  json << "{\n  \"frames\": " << options.occlusion_frames
       << ",\n  \"false_hypotheses\": " << false_hypotheses << ",\n  \"bins\": [";
  for (int b = 0; b < kBins; ++b) {
    json << (b ? ",\n" : "\n") << "    {\"occluded_from\": " << b / double(kBins)
         << ", \"occluded_to\": " << (b + 1) / double(kBins) << ", \"frames\": " << frames[b]
         << ", \"circle_found\": " << found[b]
         << ", \"rate\": " << (frames[b] ? double(found[b]) / frames[b] : 0.0) << "}";
    std::cout << "occlusion " << b * 10 << "-" << (b + 1) * 10 << "% frames=" << frames[b]
              << " circle_rate=" << (frames[b] ? double(found[b]) / frames[b] : 0.0) << "\n";
  }
  json << "\n  ]\n}\n";
  std::cout << "occlusion_false_hypotheses=" << false_hypotheses << "\n";
  if (options.out_dir.empty()) return;
  std::filesystem::create_directories(options.out_dir);
  std::ofstream(options.out_dir + "/occlusion.json") << json.str();
  // Bar chart: rate per bin, the number of frames under each bar.
  const int w = 560, h = 300, left = 50, bottom = 250, bar = 45;
  cv::Mat chart(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::line(chart, {left, bottom}, {left + kBins * (bar + 5), bottom}, {0, 0, 0});
  cv::line(chart, {left, bottom}, {left, 30}, {0, 0, 0});
  for (int b = 0; b < kBins; ++b) {
    const double rate = frames[b] ? double(found[b]) / frames[b] : 0.0;
    const int x0 = left + 5 + b * (bar + 5);
    cv::rectangle(chart, {x0, bottom - static_cast<int>(rate * 200)}, {x0 + bar, bottom},
                  {200, 120, 40}, -1);
    cv::putText(chart, std::to_string(b * 10) + "%", {x0 + 8, bottom + 16},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1, cv::LINE_AA);
    cv::putText(chart, "n=" + std::to_string(frames[b]), {x0 + 2, bottom + 32},
                cv::FONT_HERSHEY_SIMPLEX, 0.35, {80, 80, 80}, 1, cv::LINE_AA);
  }
  for (int k = 0; k <= 4; ++k) {
    cv::putText(chart, std::to_string(k * 25) + "%", {8, bottom - k * 50 + 4},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1, cv::LINE_AA);
  }
  cv::putText(chart, "centre circle found vs share of the circle occluded", {left, 20},
              cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  cv::imwrite(options.out_dir + "/occlusion.png", chart);
}

// The recogniser's and the region tracker's parameters from the options.
feature_recognition::RecognitionParams recognitionParamsOf(const Options& options) {
  feature_recognition::RecognitionParams recognition_params;
  if (options.alone_side_points >= 0)
    recognition_params.line_end_alone_side_points = options.alone_side_points;
  if (options.max_beyond_points >= -1)
    recognition_params.line_end_max_beyond_points = options.max_beyond_points;
  if (options.goal_shadow >= 0) recognition_params.model_check_goal_shadow = options.goal_shadow;
  if (options.identity_max_beyond >= -1)
    recognition_params.identity_max_beyond_points = options.identity_max_beyond;
  if (options.identity_beyond_reach >= 0.0)
    recognition_params.identity_beyond_reach = options.identity_beyond_reach;
  if (options.beyond_from >= 0.0) recognition_params.line_end_beyond_from = options.beyond_from;
  if (options.max_unseen >= -1.0) recognition_params.unseen_max_stretch = options.max_unseen;
  if (options.unseen_range > 0.0) recognition_params.unseen_range = options.unseen_range;
  if (options.veto_margin >= -1.0) recognition_params.consistency_veto_margin = options.veto_margin;
  return recognition_params;
}

region_tracking::VisionParams visionParamsOf(const Options& options) {
  region_tracking::VisionParams vision_params = region_tracking::defaultVisionParams();
  if (options.sample_spacing > 0) {
    vision_params.lines.sample_spacing = options.sample_spacing;
    vision_params.lines.sample_spacing_m = 0.0;  // sampling by contour index asked for
  }
  if (options.sample_spacing_m >= 0.0)
    vision_params.lines.sample_spacing_m = options.sample_spacing_m;
  if (options.sample_min_px > 0.0) vision_params.lines.sample_min_px = options.sample_min_px;
  if (options.turn_spacing_m >= 0.0) vision_params.lines.turn_spacing_m = options.turn_spacing_m;
  if (options.turn_reach_m >= 0.0) vision_params.lines.turn_reach_m = options.turn_reach_m;
  if (options.turn_range_m >= 0.0) vision_params.lines.turn_range_m = options.turn_range_m;
  if (options.refine_range_m >= 0.0) vision_params.lines.refine_range_m = options.refine_range_m;
  if (options.refine_min_range_m >= 0.0)
    vision_params.lines.refine_min_range_m = options.refine_min_range_m;
  if (options.refine_turn > 0.0) vision_params.lines.refine_turn = options.refine_turn;
  if (options.refine_isolated) vision_params.lines.refine_isolated = true;
  if (options.refine_spacing_m >= 0.0)
    vision_params.lines.refine_spacing_m = options.refine_spacing_m;
  if (options.refine_samples > 0) vision_params.lines.refine_samples = options.refine_samples;
  if (options.refine_reach > 0) vision_params.lines.refine_reach = options.refine_reach;
  return vision_params;
}

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
                 const perception::FieldFeatures& features) {
  Pipeline fresh(options);
  region_tracking::VisionResult fresh_vision;
  perception::FieldFeatures fresh_features;
  visionOf(fresh.sim, fresh.processor, sceneFor(pose, frame, options, fresh.sim.field),
           fresh_vision);
  fresh.recognizer.recognize(fresh_vision.lines, fresh_features);
  bool same = fresh_vision.lines.points.size() == vision.lines.points.size() &&
              fresh_vision.lines.sequences == vision.lines.sequences &&
              fresh_features.hypotheses.size() == features.hypotheses.size();
  for (std::size_t i = 0; same && i < vision.lines.points.size(); ++i) {
    same = fresh_vision.lines.points[i].x == vision.lines.points[i].x &&
           fresh_vision.lines.points[i].y == vision.lines.points[i].y;
  }
  for (std::size_t i = 0; same && i < features.hypotheses.size(); ++i) {
    const Pose2& a = features.hypotheses[i].pose;
    const Pose2& b = fresh_features.hypotheses[i].pose;
    same = a.x == b.x && a.y == b.y && a.phi == b.phi;
  }
  if (!same) {
    std::cerr << "frame " << frame << " differs from a fresh pipeline's: line points "
              << vision.lines.points.size() << " / " << fresh_vision.lines.points.size()
              << ", hypotheses " << features.hypotheses.size() << " / "
              << fresh_features.hypotheses.size() << "\n";
  }
  return same;
}

int run(const Options& options) {
  const auto pipeline = std::make_unique<Pipeline>(options);
  region_tracking::SimCamera& sim = pipeline->sim;
  feature_recognition::FeatureRecognizer& recognizer = pipeline->recognizer;
  region_tracking::FrameProcessor& processor = pipeline->processor;
  region_tracking::VisionResult vision;
  perception::FieldFeatures features;

  const std::vector<Pose2> path = scanPath(sim.field, options.frames);
  if (!options.pose.empty()) {
    Pose2 pose;
    char c1 = 0, c2 = 0;
    std::istringstream in(options.pose);
    if (!(in >> pose.x >> c1 >> pose.y >> c2 >> pose.phi) || c1 != ',' || c2 != ',') {
      std::cerr << "--pose wants x,y,phi (m, m, rad)\n";
      return 2;
    }
    return detailFrame(options, sim, processor, recognizer, pose,
                       static_cast<std::uint64_t>(std::max(options.frame, 0)));
  }
  if (options.frame >= 0) {
    if (options.frame >= static_cast<int>(path.size())) {
      std::cerr << "--frame must be below --frames\n";
      return 2;
    }
    return detailFrame(options, sim, processor, recognizer, path[options.frame],
                       static_cast<std::uint64_t>(options.frame));
  }

  const std::vector<CornerSite> sites = cornerSites(sim.field);
  const double circle_radius = sim.field.dimensions().centre_circle_radius;
  std::vector<FrameRecord> records;
  std::vector<double> position_errors, heading_errors;
  long false_hypotheses = 0, hypotheses = 0;
  long circle_eligible = 0, circle_found = 0, corner_eligible = 0, corner_found = 0;
  long frames_with_feature = 0;
  // Corners within 4 m the camera can see (seeable()) and those of them found.
  long corner_seeable = 0, corner_seeable_found = 0;
  double line_points = 0.0;
  // Line points by range from the robot: within 2 m, 2-4 m, beyond 4 m.
  std::array<double, 3> line_points_by_range{};
  // The line detector's work in the frame's second pass (its cost): scans and pixels read.
  double line_scans = 0.0, line_pixels = 0.0;
  std::ofstream check_csv, misses_csv, circle_misses_csv;
  if (!options.circle_misses_csv.empty()) {
    circle_misses_csv.open(options.circle_misses_csv);
    circle_misses_csv << "frame,x,y,phi,occluded_share,arcs,circle_found,coverage_rad,oriented,"
                         "checked,share\n";
  }
  if (!options.misses_csv.empty()) {
    misses_csv.open(options.misses_csv);
    misses_csv << "frame,inner,left,opponent_goal,distance,local_x,local_y,x,y,cause,zone,"
                  "blocked,front_visible,side_visible,front_points,side_points,front_group,"
                  "side_group,junction,structure_corner,checked\n";
  }
  if (!options.check_csv.empty()) {
    check_csv.open(options.check_csv);
    check_csv << "frame,kind,share,points,others_share,others,accepted,error_m,error_deg,"
                 "rival_share,shifted_share,side_points,beyond_points,unseen_m\n";
  }
  long fresh_checked = 0, fresh_differ = 0;
  const int last_frame = options.count > 0 ? std::min(static_cast<int>(path.size()),
                                                      options.first_frame + options.count)
                                           : static_cast<int>(path.size());
  for (int f = options.first_frame; f < last_frame; ++f) {
    const Pose2& pose = path[f];
    const camera::SimScene scene =
        sceneFor(pose, static_cast<std::uint64_t>(f), options, sim.field);
    visionOf(sim, processor, scene, vision);
    recognizer.recognize(vision.lines, features);
    if (options.check_fresh_every > 0 &&
        (f - options.first_frame) % options.check_fresh_every == 0) {
      ++fresh_checked;
      if (!sameAsFresh(options, pose, static_cast<std::uint64_t>(f), vision, features)) {
        ++fresh_differ;
      }
    }
    line_points += static_cast<double>(vision.lines.points.size());
    line_scans += processor.lineDetector().scans();
    line_pixels += processor.lineDetector().pixelsRead();
    for (const perception::LinePoint& p : vision.lines.points) {
      const double range = std::hypot(p.x, p.y);
      ++line_points_by_range[range < 2.0 ? 0 : range < kViewDistance ? 1 : 2];
    }
    const FrameResult r = evaluate(pose, features, sites, circle_radius);
    for (const auto& e : r.eligible_corners) {
      MissDiagnosis v;
      cornerVisibility(sites[e.site], pose, scene, sim, v);
      if (!seeable(v)) continue;
      ++corner_seeable;
      if (e.found) ++corner_seeable_found;
    }
    if (misses_csv.is_open()) {
      for (const auto& [site, distance, found] : r.eligible_corners) {
        if (found) continue;
        const Vec2 local = geometry::pointFieldToRobot(pose, sites[site].position);
        const MissDiagnosis m =
            diagnoseMiss(sites[site], pose, scene, sim, vision.lines, recognizer);
        misses_csv << f << "," << sites[site].inner << "," << sites[site].left << ","
                   << sites[site].opponent_goal << "," << distance << "," << local.x() << ","
                   << local.y() << "," << pose.x << "," << pose.y << "," << m.cause << "," << m.zone
                   << "," << m.blocked << "," << m.front_visible << "," << m.side_visible << ","
                   << m.front_points << "," << m.side_points << "," << m.front_group << ","
                   << m.side_group << "," << m.junction << "," << m.structure_corner << ","
                   << m.checked << "\n";
      }
    }
    if (circle_misses_csv.is_open() && r.circle_eligible && !r.circle_found) {
      // Why the centre circle was missed: occluded share, the stage reached, the model check.
      const auto& circle = recognizer.circle();
      int checked = -1;
      double share = 0.0;
      for (const auto& c : recognizer.checked()) {
        if (c.kind == FeatureKind::kCentreCircle) {
          checked = c.accepted;
          share = c.fit.share();
        }
      }
      circle_misses_csv << f << "," << pose.x << "," << pose.y << "," << pose.phi << ","
                        << occludedCircleShare(scene, circle_radius,
                                               sim.mirror.params().reference_height,
                                               sim.renderer->params().robot_height)
                        << "," << recognizer.classified().arcs.size() << "," << circle.found << ","
                        << circle.coverage << "," << circle.oriented << "," << checked << ","
                        << share << "\n";
    }
    if (check_csv.is_open()) {
      for (const auto& c : recognizer.checked()) {
        double position = 0, heading = 0;
        errorsAgainst(pose, c.robot, position, heading);
        check_csv << f << "," << static_cast<int>(c.kind) << "," << c.fit.share() << ","
                  << c.fit.points << "," << c.others.share() << "," << c.others.points << ","
                  << c.accepted << "," << position << "," << heading * 180 / kPi << ","
                  << c.rival_share << "," << c.shifted_share << "," << c.side_points << ","
                  << c.beyond_points << "," << c.unseen << "\n";
      }
    }
    if (r.false_hypotheses > 0) {
      std::cerr << "false hypothesis: frame " << f << " pose " << pose.x << "," << pose.y << ","
                << pose.phi << " (" << r.false_hypotheses << " of " << r.hypotheses << ")\n";
    }
    hypotheses += r.hypotheses;
    false_hypotheses += r.false_hypotheses;
    if (r.hypotheses > 0) ++frames_with_feature;
    circle_eligible += r.circle_eligible;
    circle_found += r.circle_found;
    corner_eligible += r.corner_eligible;
    corner_found += r.corner_found;
    position_errors.insert(position_errors.end(), r.position_errors.begin(),
                           r.position_errors.end());
    heading_errors.insert(heading_errors.end(), r.heading_errors.begin(), r.heading_errors.end());
    records.push_back(r.record);
    if (options.progress && (f + 1) % 1000 == 0) {
      std::cerr << "progress: " << f + 1 << "/" << path.size() << " false=" << false_hypotheses
                << " circle=" << circle_found << "/" << circle_eligible
                << " corner=" << corner_found << "/" << corner_eligible << std::endl;
    }
  }

  const double circle_rate = circle_eligible ? double(circle_found) / circle_eligible : 0.0;
  const double corner_rate = corner_eligible ? double(corner_found) / corner_eligible : 0.0;
  const double corner_seeable_rate =
      corner_seeable ? double(corner_seeable_found) / corner_seeable : 0.0;
  const double pos_median = median(position_errors);
  const double heading_median = median(heading_errors);
  const double points_per_frame =
      line_points / static_cast<double>(std::max<std::size_t>(records.size(), 1));
  const double frames_counted = static_cast<double>(std::max<std::size_t>(records.size(), 1));
  line_scans /= frames_counted;
  line_pixels /= frames_counted;
  for (double& count : line_points_by_range) {
    count /= static_cast<double>(std::max<std::size_t>(records.size(), 1));
  }

  if (!options.out_dir.empty()) {
    std::filesystem::create_directories(options.out_dir);
    for (int k = 0; k < kMapKinds; ++k) {
      MapCanvas canvas(sim.field, 30.0);
      for (const FrameRecord& r : records) {
        if (!r.detected[k]) cv::circle(canvas.image, canvas.px(r.position), 1, {70, 70, 70}, -1);
      }
      for (const FrameRecord& r : records) {
        if (r.detected[k]) {
          cv::circle(canvas.image, canvas.px(r.position), 2, {0, 220, 255}, -1, cv::LINE_AA);
        }
      }
      for (const FrameRecord& r : records) {
        if (r.false_hypothesis) {
          cv::drawMarker(canvas.image, canvas.px(r.position), {0, 0, 255}, cv::MARKER_CROSS, 7, 2);
        }
      }
      cv::putText(canvas.image, kMapNames[k], {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6,
                  {255, 255, 255}, 1, cv::LINE_AA);
      cv::imwrite(options.out_dir + "/detection_" + kMapNames[k] + ".png", canvas.image);
    }
    std::ofstream json(options.out_dir + "/summary.json");
    json << "{\n  \"frames\": " << records.size() << ",\n  \"field\": \"" << options.field
         << "\",\n  \"clutter\": " << (options.clutter ? "true" : "false")
         << ",\n  \"seed\": " << options.seed << ",\n  \"hypotheses\": " << hypotheses
         << ",\n  \"false_hypotheses\": " << false_hypotheses
         << ",\n  \"frames_with_hypotheses\": " << frames_with_feature
         << ",\n  \"circle_eligible_frames\": " << circle_eligible
         << ",\n  \"circle_found\": " << circle_found << ",\n  \"circle_rate\": " << circle_rate
         << ",\n  \"corner_eligible\": " << corner_eligible
         << ",\n  \"corner_found\": " << corner_found << ",\n  \"corner_rate\": " << corner_rate
         << ",\n  \"corner_seeable\": " << corner_seeable
         << ",\n  \"corner_seeable_found\": " << corner_seeable_found
         << ",\n  \"corner_seeable_rate\": " << corner_seeable_rate
         << ",\n  \"pos_median_m\": " << pos_median
         << ",\n  \"heading_median_deg\": " << heading_median
         << ",\n  \"line_points_per_frame\": " << points_per_frame
         << ",\n  \"line_points_per_frame_within_2m\": " << line_points_by_range[0]
         << ",\n  \"line_points_per_frame_2_to_4m\": " << line_points_by_range[1]
         << ",\n  \"line_points_per_frame_beyond_4m\": " << line_points_by_range[2]
         << ",\n  \"line_scans_per_frame\": " << line_scans
         << ",\n  \"line_pixels_per_frame\": " << line_pixels << "\n}\n";
  }
  if (options.occlusion_frames > 0) occlusionSeries(options, sim, processor, recognizer);

  std::cout << "line_points_per_frame=" << points_per_frame
            << " within_2m=" << line_points_by_range[0] << " 2_to_4m=" << line_points_by_range[1]
            << " beyond_4m=" << line_points_by_range[2] << " scans=" << line_scans
            << " pixels_read=" << line_pixels << "\n";
  // The corners within 4 m that the camera can see at all (see seeable()): the rest stand behind
  // an opponent, in the robot's own reflection or beyond the mirror's useful radius. Both rates
  // are reported; corner_rate in the last line counts every corner within 4 m.
  std::cout << "corner_eligible=" << corner_eligible << " corner_seeable=" << corner_seeable
            << " corner_seeable_rate=" << corner_seeable_rate << "\n";
  std::cout << "frames=" << records.size() << " false_hypotheses=" << false_hypotheses
            << " circle_rate=" << circle_rate << " corner_rate=" << corner_rate
            << " pos_median_m=" << pos_median << " heading_median_deg=" << heading_median
            << std::endl;
  if (options.check_fresh_every > 0) {
    std::cout << "fresh_checked=" << fresh_checked << " fresh_differ=" << fresh_differ << "\n";
  }
  bool ok = false_hypotheses == 0 && fresh_differ == 0;
  if (options.min_circle_rate >= 0 && circle_rate < options.min_circle_rate) ok = false;
  if (options.min_corner_rate >= 0 && corner_rate < options.min_corner_rate) ok = false;
  return ok ? 0 : 1;
}

// The command line into `options`.
void addOptions(CLI::App& app, Options& options) {
  app.add_option("--frames", options.frames, "Frames along the scanning path")
      ->check(CLI::Range(1, 10'000'000))
      ->capture_default_str();
  app.add_option("--field", options.field, "Field preset or YAML file")->capture_default_str();
  app.add_option("--camera", options.camera, "Camera preset")->capture_default_str();
  app.add_option("--sample-spacing", options.sample_spacing,
                 "The region tracker's line sample spacing in pixels (0 = its default)")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  app.add_option("--sample-spacing-m", options.sample_spacing_m,
                 "The region tracker's line sampling by distance on the field, m (0 = off, by "
                 "contour index; default: vision_default.yaml's, off with --sample-spacing)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--sample-min-px", options.sample_min_px,
                 "With --sample-spacing-m: samples at least this many pixels apart (default: "
                 "vision_default.yaml's)")
      ->check(CLI::Range(0.25, 1000.0));
  app.add_option("--turn-spacing-m", options.turn_spacing_m,
                 "With --sample-spacing-m: the spacing near the contour's turns, m (0 = none; "
                 "default: vision_default.yaml's)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--turn-reach-m", options.turn_reach_m,
                 "How far along the contour from a turn the turn spacing holds, m (default: "
                 "vision_default.yaml's)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--turn-range-m", options.turn_range_m,
                 "Only turns within this distance of the robot count, m (default: "
                 "vision_default.yaml's)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--alone-side-points", options.alone_side_points,
                 "The recogniser's line_end_alone_side_points (a line end without a parallel "
                 "partner is a corner when its other line shows this many points; 0 = off; "
                 "default: the recogniser's, 2)")
      ->check(CLI::Range(0, 100));
  app.add_option("--max-beyond-points", options.max_beyond_points,
                 "The recogniser's line_end_max_beyond_points (an L, not a T: at most this many "
                 "points near the corner off its two lines; -1 = not tested; default: the "
                 "recogniser's, 2)")
      ->check(CLI::Range(-1, 100));
  app.add_option("--identity-max-beyond", options.identity_max_beyond,
                 "The recogniser's identity_max_beyond_points (the L test for L-corners placed "
                 "by the model check, stage 8; -1 = not tested; default: the recogniser's, 2)")
      ->check(CLI::Range(-1, 100));
  app.add_option("--identity-beyond-reach", options.identity_beyond_reach,
                 "The recogniser's identity_beyond_reach (m)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--max-unseen", options.max_unseen,
                 "The recogniser's unseen_max_stretch: a pose that puts a longer stretch of line "
                 "in clear view near the robot without a line point near it is refused (m; -1 = "
                 "not tested; default: the recogniser's)")
      ->check(CLI::Range(-1.0, 100.0));
  app.add_option("--veto-margin", options.veto_margin,
                 "The recogniser's consistency_veto_margin: an accepted pose is dropped when a "
                 "refused one that implies another pose fits all points better by this share "
                 "(-1 = not tested; default: the recogniser's)")
      ->check(CLI::Range(-1.0, 1.0));
  app.add_option("--unseen-range", options.unseen_range,
                 "The recogniser's unseen_range: the unseen-lines test looks this far (m; beyond "
                 "its unseen_min_range, 0.6)")
      ->check(CLI::Range(0.7, 20.0));
  app.add_option("--beyond-from", options.beyond_from, "The recogniser's line_end_beyond_from (m)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--goal-shadow", options.goal_shadow,
                 "The recogniser's model_check_goal_shadow (1: points in a goal's shadow count "
                 "neither as fitting nor as not fitting; 0: they count; default: the "
                 "recogniser's, 1)")
      ->check(CLI::Range(0, 1));
  app.add_option("--count", options.count,
                 "Run only this many frames from --first-frame (0 = to the end of the path)")
      ->check(CLI::Range(0, 10'000'000));
  app.add_option("--check-fresh-every", options.check_fresh_every,
                 "Every N-th frame is evaluated again by a freshly built camera, region tracker "
                 "and recogniser; exit 1 if its line points or hypotheses differ (0 = never)")
      ->check(CLI::Range(0, 10'000'000));
  app.add_option("--refine-range-m", options.refine_range_m,
                 "The line detector's refinement around line ends and turns (sampling by index): "
                 "line points up to this far count, m (0 = off; default: vision_default.yaml's)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--refine-min-range-m", options.refine_min_range_m,
                 "Refinement: line points at least this far count, m")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--refine-samples", options.refine_samples,
                 "Refinement: scans added per refined sample interval")
      ->check(CLI::Range(1, 64));
  app.add_option("--refine-spacing-m", options.refine_spacing_m,
                 "Refinement: at most as many scans per interval as put them this far apart on "
                 "the floor, m (0 = always --refine-samples)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_flag("--refine-isolated", options.refine_isolated,
               "Refinement: also around line points without a neighbouring one");
  app.add_option("--refine-reach", options.refine_reach,
                 "Refinement: sample intervals refined on each side of a line's end or turn")
      ->check(CLI::Range(1, 16));
  app.add_option("--refine-turn", options.refine_turn,
                 "Refinement: a line turns where its direction changes by more than this, rad")
      ->check(CLI::Range(0.01, 3.1));
  app.add_flag("!--no-clutter", options.clutter, "No opponents or clutter");
  app.add_option("--opponents", options.opponents, "Opponents around the robot per frame")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  app.add_option("--white-robots", options.white_robot_share,
                 "Share of the opponents with a white body")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--other-colour-robots", options.other_colour_share,
                 "Share of the opponents with a third team's marker colour")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--white-objects", options.white_objects,
                 "White boxes beyond the border lines per frame")
      ->check(CLI::Range(0, 10))
      ->capture_default_str();
  app.add_option("--people", options.people, "People beyond the side lines per frame")
      ->check(CLI::Range(0, 10))
      ->capture_default_str();
  app.add_option("--patches", options.patches, "White patches on the carpet per frame")
      ->check(CLI::Range(0, 10))
      ->capture_default_str();
  app.add_option("--orange-objects", options.orange_objects,
                 "Orange objects per frame (a ball near the robot, a box beyond the border)")
      ->check(CLI::Range(0, 5))
      ->capture_default_str();
  app.add_option("--occlusion-frames", options.occlusion_frames,
                 "Frames of the occlusion series (seed fig. 4.60); 0 = none")
      ->check(CLI::Range(0, 10'000'000))
      ->capture_default_str();
  app.add_option("--first-frame", options.first_frame,
                 "Start at this frame of the --frames path (the frames before it are skipped)")
      ->check(CLI::Range(0, 10'000'000));
  app.add_option("--frame", options.frame,
                 "Evaluate only this frame of the --frames path (with its clutter) in detail")
      ->check(CLI::Range(0, 10'000'000));
  app.add_option("--image", options.image,
                 "With --frame or --pose: write the camera image with the line points (PNG)");
  app.add_flag("--progress", options.progress, "Report progress every 1000 frames on stderr");
  app.add_option("--misses-csv", options.misses_csv,
                 "Write every penalty corner within 4 m that was not found as CSV");
  app.add_option("--circle-misses-csv", options.circle_misses_csv,
                 "Write every frame with the whole centre circle within 4 m in which it was not "
                 "found as CSV (occluded share, the stage reached)");
  app.add_option("--check-csv", options.check_csv,
                 "Write every model check (fits, verdict, error of its pose) as CSV");
  app.add_option("--seed", options.seed, "Seed of the clutter placement")->capture_default_str();
  app.add_option("--out", options.out_dir, "Directory for the detection maps and summary.json");
  app.add_option("--min-circle-rate", options.min_circle_rate,
                 "Fail (exit 1) below this centre circle rate")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--min-corner-rate", options.min_corner_rate,
                 "Fail (exit 1) below this penalty corner rate")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--pose", options.pose,
                 "Evaluate one frame at x,y,phi (m, m, rad) and print its hypotheses");
  app.add_option("--dump", options.dump,
                 "With --frame or --pose: write the frame's line points as CSV");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Evaluates feature recognition on rendered frames over the whole field: detection rates, "
      "false pose hypotheses and pose errors. Exit code 1 when a hypothesis is false or a "
      "required rate is missed."};
  Options options;
  addOptions(app, options);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help exits 0; bad arguments exit 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    return run(options);
  } catch (const std::exception& e) {
    std::cerr << "fieldline-eval-features: " << e.what() << "\n";
    return 2;
  }
}
