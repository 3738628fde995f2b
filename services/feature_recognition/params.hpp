// The constants of feature recognition (seed 4.13), in SI units. Distances that belong to the
// field (circle radius, area depths and widths) are not here: they come from field::FieldModel.
#pragma once

namespace fieldline::feature_recognition {

struct RecognitionParams {
  // --- input ---
  // Frames with more points are refused as a whole (bounded time per frame).
  int max_points = 20000;
  // Sequences with fewer points carry no usable shape.
  int min_sequence_points = 3;

  // --- contour preparation (seed: smoothing, curvature, splitting) ---
  // The enclosing points for the curvature are this many indices before and after.
  int curvature_span = 4;
  // Split where the tangent turns by more than this between p[i-w]->p[i] and p[i]->p[i+w], rad.
  // (The seed divides by the distance of the vectors' centres; the point spacing grows with the
  // distance from the robot, so the turning angle itself is the scale-free test.)
  double split_turn_angle = 0.5;
  // Split maxima at least this many indices apart.
  int split_min_separation = 3;
  // Consecutive points further apart than this split a sequence (a jump over an occlusion), m.
  double split_gap = 0.6;
  // Pieces with fewer points are dropped; pieces split off during classification may be down to
  // min_split_points (far lines have few, widely spaced points).
  int min_piece_points = 3;
  int min_split_points = 3;

  // --- classification and arcs ---
  // Curved when first->middle and middle->last differ by more than this, rad.
  double curved_angle = 0.4;
  // A curved piece whose point furthest from its chord turns it by more than this (rad) and has
  // a straight leg on one side is split there into two pieces.
  double corner_split_angle = 0.8;
  // Arcs with a larger relative radius deviation are discarded.
  double max_arc_relative_deviation = 0.3;
  // Straight pieces whose points lie further than this from their fitted line (rms) are
  // discarded, m.
  double max_line_rms = 0.06;
  // Straight pieces shorter than this are not used, m.
  double min_line_length = 0.25;

  // --- centre circle ---
  // Arcs are clustered when their radius is within this fraction of the model's radius.
  double arc_radius_tolerance = 0.4;
  // Cluster radius relative to the arc's radius.
  double circle_cluster_radius = 0.6;
  // A cluster is a circle from this many points.
  int circle_min_points = 20;
  // Straight pieces re-classified as circle: centre within this fraction of r from the circle,
  // direction within this angle of the tangent (rad).
  double reclassify_distance = 0.5;
  double reclassify_angle = 0.436332313;  // 25 degrees
  int landau_iterations = 4;
  // After the fit, points further than this from the circle are dropped and the fit repeated, m.
  double circle_inlier_distance = 0.15;
  // The fitted radius must be within this fraction of the model's radius.
  double circle_radius_tolerance = 0.12;
  // Rms distance of the points from the fitted circle at most, m.
  double circle_max_rms = 0.06;
  // The points must cover at least this much of the circle's angle, rad.
  double circle_min_coverage = 1.2;
  // The orientation line passes within this distance of the centre, m, and is at least
  // min_orientation_line long.
  double orientation_line_distance = 0.3;
  double min_orientation_line = 1.0;
  // It reaches this fraction of the radius to both sides of the centre.
  double orientation_line_reach = 0.25;

  // --- principal directions, collinear groups ---
  double direction_cluster = 0.3;
  double collinear_cluster = 0.2;
  // Members of a group further apart than this along the line are separate runs (LineGroup::
  // runs): junctions and line ends are taken from the run at the place, m.
  double group_run_gap = 1.0;

  // --- penalty area ---
  // Tolerance on the spacings of the goal line, goal-area line and penalty-area line, m.
  double spacing_tolerance = 0.2;
  // Tolerance on the lengths of the area lines against the field model, m.
  double length_tolerance = 0.5;
  // A corner: the side line's end and the front line's end within this distance, m.
  double corner_distance = 0.3;
  // Without all three lines, a corner's side line must reach this far from the front line (or
  // to the goal line if that is nearer), m.
  double partial_side_line = 1.0;
  // Both lines of a corner (stage 5 or an identified L) need this many points: pieces of 3
  // points may be used for the structure's lines, but a side line that short can be a fragment
  // off the true corner by more than half a metre along the front line.
  int min_corner_line_points = 4;
  // Lines shorter than this cannot tell left from right, m.
  double min_front_line = 0.5;

  // --- junctions and straight lines (beyond the seed) ---
  // An end closer than this to another line forms a junction, m.
  double junction_distance = 0.4;
  // A line continues through a T when it reaches this far on both sides, m.
  double junction_through = 0.3;
  // Straight-line constraints from groups at least this long, m.
  double min_constraint_line = 1.0;

  // --- model check (beyond the seed) ---
  // The frame's points within model_check_range of the robot are moved into the field by a
  // hypothesis; a point fits when it lies within tolerance + tolerance_per_m * its range of a
  // model line (the line points sit on the lines' edges, and far points carry the calibration's
  // larger errors). A hypothesis needs this share of fitting points.
  double model_check_tolerance = 0.15;
  double model_check_tolerance_per_m = 0.02;
  double model_check_range = 8.0;
  double model_check_min_share = 0.75;
  // A penalty corner's other points (further than identity_leg_margin from its two lines) must be
  // at least this many and fit with this share: the corner explains its own points whatever
  // its goal direction, only the rest of the frame tells a flipped corner from the true one.
  int model_check_min_other_points = 30;
  double model_check_min_other_share = 0.75;
  // At most this many points are looked up per hypothesis (evenly thinned beyond).
  int model_check_max_points = 1000;
  // The goals' shadow: a point whose ray from the robot passes through a goal of the pose
  // checked (the goal's footprint from the mouth on, grown by model_check_tolerance at its
  // sides and back) may be the goal itself (its posts and frame, white in msl, seen as line
  // points beyond the goal line); such points count as neither fitting nor not fitting. Not for
  // a robot within model_check_tolerance of the goal's mouth or in it.
  bool model_check_goal_shadow = true;
  // Distance grid: node spacing and margin beyond the field's lines, m.
  double model_check_cell = 0.05;
  double model_check_margin = 2.0;

  // --- identifying L-corners and T-junctions by the model check (beyond the seed) ---
  // Points within this distance of the junction's own lines are not "other" points, m.
  double identity_leg_margin = 0.3;
  // An observed leg matches a model leg within this angle, rad.
  double identity_angle = 0.2;
  // The chosen place needs this many other points within the check's range and this share of
  // them on the model's lines; every rival place (not the chosen one or its point-symmetric
  // twin) must fit at least identity_margin worse.
  int identity_min_points = 25;
  double identity_min_share = 0.8;
  double identity_margin = 0.2;
  // The candidates are screened on at most this many of the other points (evenly thinned); the
  // best of them, and every rival screened within identity_margin + identity_screen_slack of it,
  // is then fitted on all of them (up to model_check_max_points) for the verdict.
  int identity_screen_points = 60;
  double identity_screen_slack = 0.15;

  // --- penalty corners from one line's end (beyond the seed, line_end_identity) ---
  // Off: no corners from line ends.
  bool line_end_corners = true;
  // Only ends within this distance of the robot are placed, m.
  double line_end_range = 4.5;
  // The penalty-corner candidates are screened on at most this many other points first.
  int line_end_screen_points = 30;
  // The chosen pose shifted along the line by this much, m, each way, must fit the other points
  // at least line_end_shift_margin (share) worse.
  double line_end_shift = 0.5;
  double line_end_shift_margin = 0.1;
  // The corner's other line must show at least this many points (within 0.1 m + 2 cm per metre
  // of range of its first line_end_side_reach metres, from 0.1 m on) at the refined pose: a line
  // that merely stops (occluded, out of view) has nothing there.
  int line_end_min_side_points = 1;
  // A line without a parallel partner at the area's spacings (the area's other lines too far or
  // too sparse) may still end at a corner when its other line shows this many points there
  // (0 = such ends are not tried). 2 needs the L test below and the refined line sampling
  // (vision_default.yaml): without them 100,000 frames gave 6-8 false hypotheses (the halfway
  // line's end at a touch line, pieces of the centre circle read as a penalty corner).
  int line_end_alone_side_points = 2;
  double line_end_side_reach = 0.6;
  // An L, not a T: within line_end_side_reach of the corner, off its two lines (pointsOffLegs),
  // at most this many points (negative = not tested): at a penalty corner nothing else is near.
  int line_end_max_beyond_points = 2;
  // ... counted from this distance of the corner on, m.
  double line_end_beyond_from = 0.1;
  // Both lines of an L placed by junction_identity are at least this long, m.
  double min_identity_leg = 0.35;
  // The same L test for such an L placed at a penalty corner: at most this many points within
  // line_end_side_reach of the model's corner (from line_end_beyond_from on) off the model
  // junction's legs (negative = not tested). Two pieces of the centre circle meeting at an
  // angle were once placed as a penalty corner (docs/feature_recognition.md, frame 87411).
  int identity_max_beyond_points = 2;
  // ... counted up to this distance of the corner, m. Short: both lines are seen, and a true
  // corner near the robot often has a white patch or the goal line within 0.4-0.6 m (3000
  // frames: 2-4 of 2802 corners lost with 0.4-0.6 m, none with 0.3 m, where the refined
  // sampling still puts 3-4 points of a crossing line).
  double identity_beyond_reach = 0.3;

  // --- unseen lines (beyond the seed, unseen_lines.hpp) ---
  // A high-level feature's pose is refused when it puts a stretch of model line longer than
  // unseen_max_stretch (m; negative = not tested) where the frame must have shown it: between
  // unseen_min_range and unseen_range of the robot, no line point within unseen_cover of it (on
  // a 10 cm map: cell centre to cell centre, so 0.2-0.4 m for 0.3), and
  // a point seen at least unseen_beyond further out in the same unseen_bearing_bin (rad) of
  // bearings (nothing stood in front of it). 1.2 m: in 100,000 frames 30 of 99,126 true poses
  // tested had a longer stretch, the two far-off poses it refuses 1.3 and 1.65 m
  // (docs/feature_recognition.md, "What is missing counts too").
  double unseen_max_stretch = 1.2;
  double unseen_range = 3.5;
  double unseen_min_range = 0.6;
  double unseen_cover = 0.3;
  double unseen_beyond = 0.3;
  double unseen_bearing_bin = 0.035;

  // --- consistency of one frame's high-level features (beyond the seed) ---
  // Features whose robot poses differ (and differ from each other's point-symmetric twin) by
  // more than this (m, rad) cannot both be right: only the one whose pose fits the most points
  // is kept.
  double consistency_distance = 0.3;
  double consistency_angle = 0.1;
  // A feature's pose is dropped too when a refused feature of the frame (refused by its own
  // tests: too few points of its own, a rival, the L test; not by unseen lines) fits all the
  // points better by at least this share and implies another pose (negative = not tested).
  double consistency_veto_margin = 0.04;

  // --- pose hypotheses ---
  // Floors on the standard deviations (the fit's own residuals underestimate the calibration's
  // errors), m and rad.
  double min_sigma_xy = 0.02;
  double min_sigma_phi = 0.005;
};

}  // namespace fieldline::feature_recognition
