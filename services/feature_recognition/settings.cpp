// Every feature recognition setting, declared once (common/config/settings.hpp): key (the
// member's name), range, unit, why. The defaults are RecognitionParams' initializers;
// config/feature_recognition/default.yaml is `fieldline-feature-recognition --print-config
// --config none` and docs/settings/feature_recognition.md the table (both checked by
// tests/unit/feature_recognition/settings_test.cpp).
#include "services/feature_recognition/settings.hpp"

namespace fieldline::feature_recognition {

// long: a table of declarations, one row per setting, read top to bottom like the YAML.
const config::SettingsTable<RecognitionParams>& recognitionSettings() {
  static const auto table = [] {
    config::SettingsTable<RecognitionParams> t;
    using RP = RecognitionParams;
    t.add("max_points", 1, 1000000, "1",
          "Frames with more points are refused as a whole (bounded time per frame)",
          &RP::max_points);
    t.add("min_sequence_points", 1, 100000, "1",
          "Sequences with fewer points carry no usable shape", &RP::min_sequence_points);
    t.add("curvature_span", 1, 100000, "1",
          "The enclosing points for the curvature are this many indices before and after",
          &RP::curvature_span);
    t.add("split_turn_angle", 0.0, 3.2, "rad",
          "Split where the tangent turns by more than this (the turn itself is scale-free)",
          &RP::split_turn_angle);
    t.add("split_min_separation", 1, 100000, "1", "Split maxima at least this many indices apart",
          &RP::split_min_separation);
    t.add("split_gap", 0.0, 100.0, "m",
          "Consecutive points further apart than this split a sequence (a jump over an occlusion)",
          &RP::split_gap);
    t.add("min_piece_points", 1, 100000, "1", "Pieces with fewer points are dropped",
          &RP::min_piece_points);
    t.add("min_split_points", 1, 100000, "1",
          "... or down to this for pieces split off during classification (far lines have few, "
          "widely spaced points)",
          &RP::min_split_points);
    t.add("curved_angle", 0.0, 3.2, "rad",
          "Curved when first->middle and middle->last differ by more than this", &RP::curved_angle);
    t.add("corner_split_angle", 0.0, 3.2, "rad",
          "A curved piece turned by more than this at its furthest point with a straight leg is "
          "split there",
          &RP::corner_split_angle);
    t.add("max_arc_relative_deviation", 0.0, 100.0, "1",
          "Arcs with a larger relative radius deviation are discarded",
          &RP::max_arc_relative_deviation);
    t.add("max_line_rms", 0.0, 100.0, "m",
          "Straight pieces whose points lie further (rms) from their fitted line are discarded",
          &RP::max_line_rms);
    t.add("min_line_length", 0.0, 100.0, "m", "Straight pieces shorter than this are not used",
          &RP::min_line_length);
    t.add("arc_radius_tolerance", 0.0, 100.0, "1",
          "Arcs are clustered when their radius is within this fraction of the model's radius",
          &RP::arc_radius_tolerance);
    t.add("circle_cluster_radius", 0.0, 100.0, "1", "Cluster radius relative to the arc's radius",
          &RP::circle_cluster_radius);
    t.add("circle_min_points", 1, 100000, "1", "A cluster is a circle from this many points",
          &RP::circle_min_points);
    t.add("reclassify_distance", 0.0, 100.0, "1",
          "Straight pieces are re-classified as circle with the centre within this fraction of r "
          "from the circle",
          &RP::reclassify_distance);
    t.add("reclassify_angle", 0.0, 3.2, "rad", "... and direction within this angle of the tangent",
          &RP::reclassify_angle);
    t.add("landau_iterations", 1, 100000, "1", "Iterations of the Landau circle fit",
          &RP::landau_iterations);
    t.add("circle_inlier_distance", 0.0, 100.0, "m",
          "After the fit, points further from the circle are dropped and the fit repeated",
          &RP::circle_inlier_distance);
    t.add("circle_radius_tolerance", 0.0, 100.0, "1",
          "The fitted radius must be within this fraction of the model's radius",
          &RP::circle_radius_tolerance);
    t.add("circle_max_rms", 0.0, 100.0, "m",
          "Rms distance of the points from the fitted circle at most", &RP::circle_max_rms);
    t.add("circle_min_coverage", 0.0, 6.3, "rad",
          "The points must cover at least this much of the circle's angle",
          &RP::circle_min_coverage);
    t.add("orientation_line_distance", 0.0, 100.0, "m",
          "The orientation line passes within this distance of the centre",
          &RP::orientation_line_distance);
    t.add("min_orientation_line", 0.0, 100.0, "m", "The orientation line is at least this long",
          &RP::min_orientation_line);
    t.add("orientation_line_reach", 0.0, 100.0, "1",
          "It reaches this fraction of the radius to both sides of the centre",
          &RP::orientation_line_reach);
    t.add("direction_cluster", 0.0, 3.2, "rad",
          "Line directions within this angle form one principal direction", &RP::direction_cluster);
    t.add("collinear_cluster", 0.0, 100.0, "m",
          "Lines of a direction within this distance of each other form one collinear group",
          &RP::collinear_cluster);
    t.add("group_run_gap", 0.0, 100.0, "m",
          "Members of a group further apart along the line are separate runs", &RP::group_run_gap);
    t.add("spacing_tolerance", 0.0, 100.0, "m",
          "Tolerance on the spacings of the goal line, goal-area line and penalty-area line",
          &RP::spacing_tolerance);
    t.add("length_tolerance", 0.0, 100.0, "m",
          "Tolerance on the lengths of the area lines against the field model",
          &RP::length_tolerance);
    t.add("corner_distance", 0.0, 100.0, "m",
          "A corner: the side line's end and the front line's end within this distance",
          &RP::corner_distance);
    t.add("partial_side_line", 0.0, 100.0, "m",
          "Without all three lines a corner's side line must reach this far from the front line",
          &RP::partial_side_line);
    t.add("min_corner_line_points", 1, 100000, "1",
          "Both lines of a corner need this many points (a shorter side line can be a fragment off "
          "the true corner)",
          &RP::min_corner_line_points);
    t.add("min_front_line", 0.0, 100.0, "m", "Lines shorter than this cannot tell left from right",
          &RP::min_front_line);
    t.add("junction_distance", 0.0, 100.0, "m",
          "An end closer than this to another line forms a junction", &RP::junction_distance);
    t.add("junction_through", 0.0, 100.0, "m",
          "A line continues through a T when it reaches this far on both sides",
          &RP::junction_through);
    t.add("min_constraint_line", 0.0, 100.0, "m",
          "Straight-line constraints from groups at least this long", &RP::min_constraint_line);
    t.add("model_check_tolerance", 0.0, 100.0, "m",
          "A point moved into the field by a hypothesis fits when it lies within this (plus "
          "tolerance_per_m times its range) of a model line",
          &RP::model_check_tolerance);
    t.add("model_check_tolerance_per_m", 0.0, 100.0, "m/m",
          "... plus this per metre of the point's range (far points carry the calibration's larger "
          "errors)",
          &RP::model_check_tolerance_per_m);
    t.add("model_check_range", 0.0, 100.0, "m",
          "Only points within this range of the robot are checked", &RP::model_check_range);
    t.add("model_check_min_share", 0.0, 1.0, "1", "A hypothesis needs this share of fitting points",
          &RP::model_check_min_share);
    t.add("model_check_min_other_points", 1, 100000, "1",
          "A penalty corner needs this many points off its own two lines",
          &RP::model_check_min_other_points);
    t.add("model_check_min_other_share", 0.0, 1.0, "1",
          "... and this share of them must fit (only the rest of the frame tells a flipped corner "
          "from the true one)",
          &RP::model_check_min_other_share);
    t.add("model_check_max_points", 1, 1000000, "1",
          "At most this many points are looked up per hypothesis (evenly thinned beyond)",
          &RP::model_check_max_points);
    t.addBool("model_check_goal_shadow",
              "Points whose ray passes through a goal of the checked pose may be the goal itself "
              "and count neither way",
              &RP::model_check_goal_shadow);
    t.add("model_check_cell", 0.005, 1.0, "m", "The model check's distance grid node spacing",
          &RP::model_check_cell);
    t.add("model_check_margin", 0.0, 100.0, "m",
          "The distance grid reaches this beyond the field's lines", &RP::model_check_margin);
    t.add("identity_leg_margin", 0.0, 100.0, "m",
          "Points within this distance of the junction's own lines are not \"other\" points",
          &RP::identity_leg_margin);
    t.add("identity_angle", 0.0, 3.2, "rad",
          "An observed leg matches a model leg within this angle", &RP::identity_angle);
    t.add("identity_min_points", 1, 100000, "1",
          "An identified L or T needs this many other points within the check's range",
          &RP::identity_min_points);
    t.add("identity_min_share", 0.0, 1.0, "1", "... and this share of them on the model's lines",
          &RP::identity_min_share);
    t.add("identity_margin", 0.0, 100.0, "1",
          "Every rival place (not the chosen one or its twin) must fit at least this share worse",
          &RP::identity_margin);
    t.add("identity_screen_points", 1, 100000, "1",
          "The candidates are screened on at most this many of the other points (evenly thinned)",
          &RP::identity_screen_points);
    t.add("identity_screen_slack", 0.0, 100.0, "1",
          "Rivals screened within identity_margin plus this of the best are fitted on all points "
          "for the verdict",
          &RP::identity_screen_slack);
    t.addBool("line_end_corners", "Penalty corners from one line's end (false: none)",
              &RP::line_end_corners);
    t.add("line_end_range", 0.0, 100.0, "m",
          "Only ends within this distance of the robot are placed", &RP::line_end_range);
    t.add("line_end_screen_points", 1, 100000, "1",
          "The penalty-corner candidates are screened on at most this many other points first",
          &RP::line_end_screen_points);
    t.add("line_end_shift", 0.0, 100.0, "m",
          "The chosen pose shifted along the line by this each way must fit worse",
          &RP::line_end_shift);
    t.add("line_end_shift_margin", 0.0, 100.0, "1",
          "... must fit the other points at least this share worse", &RP::line_end_shift_margin);
    t.add("line_end_min_side_points", 0, 100000, "1",
          "The corner's other line must show at least this many points at the refined pose (a line "
          "that merely stops has none)",
          &RP::line_end_min_side_points);
    t.add("line_end_alone_side_points", 0, 100000, "1",
          "A line without a parallel partner may end at a corner when its other line shows this "
          "many points there (0: not tried)",
          &RP::line_end_alone_side_points);
    t.add("line_end_side_reach", 0.0, 100.0, "m",
          "The corner's other line is looked for within this of the corner",
          &RP::line_end_side_reach);
    t.add("line_end_max_beyond_points", -1, 100000, "1",
          "An L, not a T: at most this many points near the corner off its two lines (negative: "
          "not tested)",
          &RP::line_end_max_beyond_points);
    t.add("line_end_beyond_from", 0.0, 100.0, "m",
          "... counted from this distance of the corner on", &RP::line_end_beyond_from);
    t.add("min_identity_leg", 0.0, 100.0, "m",
          "Both lines of an L placed by junction_identity are at least this long",
          &RP::min_identity_leg);
    t.add("identity_max_beyond_points", -1, 100000, "1",
          "An L placed by junction_identity at a penalty corner: at most this many points off its "
          "legs near the corner (negative: not tested)",
          &RP::identity_max_beyond_points);
    t.add("identity_beyond_reach", 0.0, 100.0, "m",
          "... counted up to this distance of the corner (a true corner often has a patch or the "
          "goal line within 0.4-0.6 m)",
          &RP::identity_beyond_reach);
    t.add("unseen_max_stretch", -1.0, 100.0, "m",
          "A feature's pose is refused when it puts a longer stretch of model line where the frame "
          "must have shown it (negative: not tested; 1.2 m refuses far-off poses, 30 of 99,126 "
          "true ones in 100,000 frames)",
          &RP::unseen_max_stretch);
    t.add("unseen_range", 0.0, 100.0, "m",
          "... between unseen_min_range and this range of the robot", &RP::unseen_range);
    t.add("unseen_min_range", 0.0, 100.0, "m", "... from this range of the robot on",
          &RP::unseen_min_range);
    t.add("unseen_cover", 0.0, 100.0, "m",
          "A model line stretch is seen when a line point lies within this of it",
          &RP::unseen_cover);
    t.add("unseen_beyond", 0.0, 100.0, "m",
          "... and nothing stood in front: a point seen at least this further out in the same "
          "bearing bin",
          &RP::unseen_beyond);
    t.add("unseen_bearing_bin", 0.0, 3.2, "rad", "Width of the bearing bins for unseen_beyond",
          &RP::unseen_bearing_bin);
    t.add("consistency_distance", 0.0, 100.0, "m",
          "Features whose robot poses differ (and differ from each other's twin) by more cannot "
          "both be right: the one fitting most points is kept",
          &RP::consistency_distance);
    t.add("consistency_angle", 0.0, 3.2, "rad", "The same in heading", &RP::consistency_angle);
    t.add("consistency_veto_margin", -1.0, 100.0, "1",
          "A feature's pose is dropped when a refused feature fits all points better by this share "
          "(negative: not tested)",
          &RP::consistency_veto_margin);
    t.add("min_sigma_xy", 0.0, 100.0, "m",
          "Floor of a hypothesis' position sigma: the fit's own residuals underestimate the "
          "calibration's errors",
          &RP::min_sigma_xy);
    t.add("min_sigma_phi", 0.0, 3.2, "rad", "Floor of a hypothesis' heading sigma",
          &RP::min_sigma_phi);
    return t;
  }();
  return table;
}

RecognitionParams loadRecognitionParams(const config::Node& root) {
  return recognitionSettings().load(root);
}

RecognitionParams loadRecognitionPreset(const std::string& name_or_path) {
  if (name_or_path == "none") return RecognitionParams{};
  return loadRecognitionParams(
      config::Node::loadFile(config::resolvePreset("feature_recognition", name_or_path)));
}

std::string recognitionConfigYaml(const RecognitionParams& p) {
  return recognitionSettings().yaml(
      p,
      "# fieldline-feature-recognition settings (docs/feature_recognition.md; every key:\n"
      "# docs/settings/feature_recognition.md). Written by `fieldline-feature-recognition\n"
      "# --print-config --config none`: the values are the code's defaults\n"
      "# (services/feature_recognition/settings.cpp declares each once), and a test checks that\n"
      "# this file equals them. Every key is optional; an unknown key or a value out of range\n"
      "# stops the process with file:line. SI units: metres, radians.\n");
}

std::string recognitionSettingsMarkdown() {
  return "# Feature recognition settings\n\n"
         "Every key of `config/feature_recognition/*.yaml` (`fieldline-feature-recognition "
         "--config`), with the code's default, which is what ships in "
         "`config/feature_recognition/default.yaml`. Written by `fieldline-feature-recognition "
         "--print-settings-table`; a test checks it against the declarations in "
         "`services/feature_recognition/settings.cpp`. What each step does: "
         "[docs/feature_recognition.md](../feature_recognition.md).\n\n" +
         recognitionSettings().markdown(RecognitionParams{});
}

}  // namespace fieldline::feature_recognition
