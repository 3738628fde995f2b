#include "services/region_tracking/frame_processor.hpp"

#include <stdexcept>
#include <string>

namespace fieldline::region_tracking {

namespace {

using camera::ColourClass;

std::optional<ClassId> classByName(const std::string& name) {
  const std::optional<ColourClass> colour = camera::colourFromName(name);
  if (!colour || *colour == ColourClass::kUnknown) return std::nullopt;
  return classIdOf(*colour);
}

ColourClass colourAt(const config::Node& node, const std::string& key) {
  const std::optional<ColourClass> colour = camera::colourFromName(node.get<std::string>(key));
  if (!colour || *colour == ColourClass::kUnknown) node.fail(key, "unknown colour class");
  return *colour;
}

}  // namespace

VisionParams defaultVisionParams() {
  VisionParams params;
  params.tracker.cell_size = 4;
  params.tracker.reinitialise_period_frames = 300;
  // The outer rim of the view checked every 2nd frame (docs/region_tracking.md, "Bounded
  // staleness at the rim"); the inner edge every frame.
  params.tracker.mask_edge_every = 2;
  const ClassId green = classIdOf(ColourClass::kGreen);
  params.tracker.classes.push_back({.class_id = green,
                                    .search_when_lost = true,
                                    .max_seed_regions = 0,
                                    .min_seed_cells = 4,
                                    .seed_from_boundary_of = kNoClass,
                                    .view_edge_stride = 4});
  for (const ColourClass c :
       {ColourClass::kYellow, ColourClass::kBlue, ColourClass::kOrange, ColourClass::kBlack}) {
    // The ball is small and fast: when it is lost, look for it inside green too.
    params.tracker.classes.push_back(
        {.class_id = classIdOf(c),
         .search_when_lost = false,
         .max_seed_regions = 0,
         .min_seed_cells = 1,
         .seed_from_boundary_of = green,
         .search_inside_parent_stride = c == ColourClass::kOrange ? 4 : 0});
  }
  return params;
}

namespace {

void loadBlockParams(const config::Node& blocks, BlockClassifierParams& out) {
  out.claims.clear();
  for (const config::Node& claim : blocks.children("claims")) {
    out.claims.push_back({colourAt(claim, "class"), claim.get<double>("min_fraction", 0.0, 1.0)});
    claim.rejectUnknownKeys();
  }
  blocks.rejectUnknownKeys();
}

LineDetectorParams loadLineParams(const config::Node& lines) {
  LineDetectorParams params;
  params.line_width = lines.get<double>("line_width", 0.01, 1.0);
  params.width_tolerance = lines.get<double>("width_tolerance", 1.0, 10.0);
  params.max_transition_pixels = lines.get<int>("max_transition_pixels", 0, 10);
  const LineDetectorParams lineDefaults;
  params.max_gap_pixels = lines.getOr<int>("max_gap_pixels", lineDefaults.max_gap_pixels, 0, 10);
  params.field_confirm_pixels =
      lines.getOr<int>("field_confirm_pixels", lineDefaults.field_confirm_pixels, 1, 10);
  params.end_at_self = lines.getOr<bool>("end_at_self", lineDefaults.end_at_self);
  params.ridge_contrast =
      lines.getOr<double>("ridge_contrast", lineDefaults.ridge_contrast, 0.0, 10.0);
  if (params.ridge_contrast > 0.0 && params.ridge_contrast < 1.0) {
    lines.fail("ridge_contrast", "must be 0 (off) or at least 1");
  }
  params.ridge_min_levels =
      lines.getOr<int>("ridge_min_levels", lineDefaults.ridge_min_levels, 0, 255);
  params.sample_spacing = lines.get<int>("sample_spacing", 1, 64);
  params.sample_spacing_m =
      lines.getOr<double>("sample_spacing_m", lineDefaults.sample_spacing_m, 0.0, 10.0);
  params.sample_min_px =
      lines.getOr<double>("sample_min_px", lineDefaults.sample_min_px, 0.25, 1000.0);
  params.turn_spacing_m =
      lines.getOr<double>("turn_spacing_m", lineDefaults.turn_spacing_m, 0.0, 10.0);
  params.turn_reach_m = lines.getOr<double>("turn_reach_m", lineDefaults.turn_reach_m, 0.0, 100.0);
  params.turn_range_m = lines.getOr<double>("turn_range_m", lineDefaults.turn_range_m, 0.0, 100.0);
  params.turn_angle = lines.getOr<double>("turn_angle", lineDefaults.turn_angle, 0.01, 1.5);
  params.turn_span = lines.getOr<int>("turn_span", lineDefaults.turn_span, 1, 100);
  params.refine_range_m =
      lines.getOr<double>("refine_range_m", lineDefaults.refine_range_m, 0.0, 100.0);
  params.refine_min_range_m =
      lines.getOr<double>("refine_min_range_m", lineDefaults.refine_min_range_m, 0.0, 100.0);
  params.refine_samples = lines.getOr<int>("refine_samples", lineDefaults.refine_samples, 1, 64);
  params.refine_spacing_m =
      lines.getOr<double>("refine_spacing_m", lineDefaults.refine_spacing_m, 0.0, 10.0);
  params.refine_isolated = lines.getOr<bool>("refine_isolated", lineDefaults.refine_isolated);
  params.refine_reach = lines.getOr<int>("refine_reach", lineDefaults.refine_reach, 1, 16);
  params.refine_turn = lines.getOr<double>("refine_turn", lineDefaults.refine_turn, 0.01, 3.1);
  params.smoothing_passes = lines.get<int>("smoothing_passes", 0, 20);
  params.tangent_half_span = lines.get<int>("tangent_half_span", 1, 20);
  params.min_contour_points = lines.get<int>("min_contour_points", 4, 100000);
  params.max_gap_samples = lines.get<int>("max_gap_samples", 0, 20);
  lines.rejectUnknownKeys();
  return params;
}

BallParams loadBallParams(const config::Node& ball) {
  BallParams params;
  params.centre_height = ball.get<double>("centre_height", 0.0, 0.5);
  params.min_pixels = ball.get<int>("min_pixels", 1, 10000);
  const BallParams ballDefaults;
  params.size_tolerance =
      ball.getOr<double>("size_tolerance", ballDefaults.size_tolerance, 1.0, 10.0);
  params.size_slack_px = ball.getOr<double>("size_slack_px", ballDefaults.size_slack_px, 0.0, 20.0);
  params.min_fill = ball.getOr<double>("min_fill", ballDefaults.min_fill, 0.0, 1.0);
  params.min_carpet_share =
      ball.getOr<double>("min_carpet_share", ballDefaults.min_carpet_share, 0.0, 1.0);
  params.field_margin_m =
      ball.getOr<double>("field_margin_m", ballDefaults.field_margin_m, 0.0, 10.0);
  ball.rejectUnknownKeys();
  return params;
}

}  // namespace

VisionParams loadVisionParams(const config::Node& node) {
  VisionParams params;
  params.tracker = loadTrackerConfig(node.child("tracker"), classByName);
  loadBlockParams(node.child("blocks"), params.blocks);
  params.lines = loadLineParams(node.child("lines"));
  params.ball = loadBallParams(node.child("ball"));
  const config::Node obstacles = node.child("obstacles");
  params.obstacles.min_cells = obstacles.get<int>("min_cells", 1, 100000);
  obstacles.rejectUnknownKeys();
  return params;
}

FrameProcessor::FrameProcessor(const camera::MirrorModel& mirror, const camera::ColourTable& table,
                               const VisionParams& params)
    : mirror_(mirror),
      table_(table),
      lookup_(table),
      lookup_generation_(table.generation()),
      grid_(CellGrid::forImage(mirror.width(), mirror.height(), params.tracker.cell_size)),
      dont_touch_(dontTouchCells(mirror, grid_)),
      floor_(mirror),
      classifier_(table, lookup_, grid_.cell_size, params.blocks),
      tracker_(grid_, params.tracker, dont_touch_),
      lines_(lookup_, floor_, params.lines, grid_.cell_size),
      ball_(table, mirror, params.ball),
      obstacles_(mirror, params.obstacles) {}

void FrameProcessor::process(const camera::FrameView& frame, bool detectLines, VisionResult& out) {
  if (!frame.valid()) throw std::invalid_argument("region tracking: invalid frame view");
  if (frame.width != mirror_.width() || frame.height != mirror_.height()) {
    throw std::invalid_argument("region tracking: frame is " + std::to_string(frame.width) + "x" +
                                std::to_string(frame.height) + ", camera model expects " +
                                std::to_string(mirror_.width()) + "x" +
                                std::to_string(mirror_.height()));
  }
  // A table adapted or replaced since the last frame (by whoever holds it): take its classes.
  if (lookup_generation_ != table_.generation()) coloursChanged();
  classifier_.setFrame(frame);
  // The frame may point into a receive buffer that is reused after this call: let go of it
  // however the call ends.
  struct LetGo {
    FrameCellClassifier& classifier;
    ~LetGo() { classifier.setFrame(camera::FrameView{}); }
  } let_go{classifier_};
  out.tracking = tracker_.track(classifier_);
  out.lines_detected = detectLines;
  if (detectLines) {
    lines_.detect(frame, tracker_.contours(), out.lines);
  } else {
    out.lines.clear();
  }
  out.ball = ball_.detect(frame, tracker_.contours(), ball_region_ ? &*ball_region_ : nullptr);
  obstacles_.detect(tracker_.contours(), out.obstacles);
}

}  // namespace fieldline::region_tracking
