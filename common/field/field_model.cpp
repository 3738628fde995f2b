#include "common/field/field_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <utility>

namespace fieldline::field {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Tolerance for angles at the ends of an arc: rounding must not push an end point off the arc.
constexpr double kAngleTolerance = 1e-12;

// A problem with a set of dimensions: the preset key it belongs to and what is wrong.
struct DimensionProblem {
  std::string key;
  std::string what;
};

bool isPositive(double v) {
  return std::isfinite(v) && v > 0.0;
}

// Every required length positive, every optional one positive or 0 (0 means "the field has
// none"), and each area given with both its depth and its width.
std::optional<DimensionProblem> checkValues(const FieldDimensions& d) {
  const std::pair<const char*, double> required[] = {
      {"length", d.length},
      {"width", d.width},
      {"line_width", d.line_width},
      {"boundary_line_width", d.boundary_line_width},
      {"goals.width", d.goal_width},
      {"goals.depth", d.goal_depth},
      {"goals.height", d.goal_height},
  };
  for (const auto& [key, value] : required) {
    if (!isPositive(value)) return DimensionProblem{key, "must be positive (at line centres)"};
  }
  const std::pair<const char*, double> optional[] = {
      {"centre_circle_radius", d.centre_circle_radius},
      {"corner_arc_radius", d.corner_arc_radius},
      {"penalty_area.depth", d.penalty_area_depth},
      {"penalty_area.width", d.penalty_area_width},
      {"goal_area.depth", d.goal_area_depth},
      {"goal_area.width", d.goal_area_width},
      {"penalty_arc.radius", d.penalty_arc_radius},
  };
  for (const auto& [key, value] : optional) {
    if (!(std::isfinite(value) && value >= 0.0)) {
      return DimensionProblem{key, "must be positive at line centres (or absent)"};
    }
  }
  if (!std::isfinite(d.border_width) || d.border_width < 0.0) {
    return DimensionProblem{"border_width", "must not be negative"};
  }
  if ((d.penalty_area_width > 0.0) != (d.penalty_area_depth > 0.0)) {
    return DimensionProblem{"penalty_area.width", "depth and width must both be given"};
  }
  if ((d.goal_area_width > 0.0) != (d.goal_area_depth > 0.0)) {
    return DimensionProblem{"goal_area.width", "depth and width must both be given"};
  }
  return std::nullopt;
}

// The goal area inside the penalty area, both narrower than the field and short of the centre
// circle.
std::optional<DimensionProblem> checkAreas(const FieldDimensions& d) {
  const bool penalty_area = d.penalty_area_depth > 0.0;
  const double half_length = d.length / 2.0;
  const double circle = d.centre_circle_radius;
  if (penalty_area) {
    if (d.penalty_area_width >= d.width) {
      return DimensionProblem{"penalty_area.width", "must be less than the field width"};
    }
    if (d.penalty_area_depth + circle >= half_length) {
      return DimensionProblem{"penalty_area.depth",
                              "penalty area reaches the centre circle or the halfway line (depth "
                              "+ circle radius must be less than half the length)"};
    }
  }
  if (d.goal_area_depth > 0.0) {
    if (penalty_area && d.goal_area_width >= d.penalty_area_width) {
      return DimensionProblem{"goal_area.width", "must be less than the penalty area width"};
    }
    if (penalty_area && d.goal_area_depth >= d.penalty_area_depth) {
      return DimensionProblem{"goal_area.depth", "must be less than the penalty area depth"};
    }
    if (d.goal_area_width >= d.width) {
      return DimensionProblem{"goal_area.width", "must be less than the field width"};
    }
    if (d.goal_area_depth + circle >= half_length) {
      return DimensionProblem{"goal_area.depth",
                              "goal area reaches the centre circle or the halfway line"};
    }
  }
  return std::nullopt;
}

// The corner arcs stay clear of the lines nearest the corners.
std::optional<DimensionProblem> checkCornerArcs(const FieldDimensions& d) {
  if (d.corner_arc_radius <= 0.0) return std::nullopt;
  const double half_length = d.length / 2.0;
  const double half_width = d.width / 2.0;
  // The widest area (or the goal) decides how close to the corner a line comes.
  double side_clear = half_width - d.goal_width / 2.0;
  double end_clear = half_length - d.centre_circle_radius;
  if (d.penalty_area_depth > 0.0) {
    side_clear = half_width - d.penalty_area_width / 2.0;
    end_clear = half_length - d.penalty_area_depth;
  } else if (d.goal_area_depth > 0.0) {
    side_clear = half_width - d.goal_area_width / 2.0;
    end_clear = half_length - d.goal_area_depth;
  }
  if (d.corner_arc_radius >= side_clear || d.corner_arc_radius >= end_clear) {
    return DimensionProblem{"corner_arc_radius",
                            "corner arc reaches the penalty area lines (or the goal, the "
                            "halfway line)"};
  }
  return std::nullopt;
}

std::optional<DimensionProblem> checkPenaltyMarks(const FieldDimensions& d) {
  if (!d.has_penalty_marks) return std::nullopt;
  if (!isPositive(d.penalty_mark_diameter)) {
    return DimensionProblem{"penalty_marks.diameter", "must be positive"};
  }
  if (!isPositive(d.penalty_mark_distance) || d.penalty_mark_distance >= d.length / 2.0) {
    return DimensionProblem{"penalty_marks.distance",
                            "must be positive and less than half the length"};
  }
  return std::nullopt;
}

// The penalty arc bulges out of the penalty area's front line, between its side lines, short of
// the centre circle.
std::optional<DimensionProblem> checkPenaltyArc(const FieldDimensions& d) {
  if (d.penalty_arc_radius <= 0.0) return std::nullopt;
  const double half_length = d.length / 2.0;
  const double r = d.penalty_arc_radius;
  const double front = d.penalty_area_depth - d.penalty_arc_centre_distance;
  if (d.penalty_area_depth <= 0.0) {
    return DimensionProblem{"penalty_arc.radius", "a penalty arc needs a penalty area"};
  }
  if (!isPositive(d.penalty_arc_centre_distance) || d.penalty_arc_centre_distance >= half_length) {
    return DimensionProblem{"penalty_arc.centre_distance",
                            "must be positive and less than half the length"};
  }
  if (std::abs(front) >= r) {
    return DimensionProblem{"penalty_arc.radius",
                            "the arc does not reach beyond the penalty area's front line"};
  }
  if (std::sqrt(r * r - front * front) >= d.penalty_area_width / 2.0) {
    return DimensionProblem{"penalty_arc.radius",
                            "the arc meets the front line outside the penalty area"};
  }
  if (d.penalty_arc_centre_distance + r + d.centre_circle_radius >= half_length) {
    return DimensionProblem{"penalty_arc.radius",
                            "the arc reaches the centre circle or the halfway line"};
  }
  return std::nullopt;
}

// Consistency checks beyond single-value ranges, so that every preset yields lines that neither
// overlap nor leave the field. Keys are the preset's (see loadFieldModel). The first problem in
// this order is reported.
std::optional<DimensionProblem> checkDimensions(const FieldDimensions& d) {
  if (auto problem = checkValues(d)) return problem;
  if (d.width > d.length) return DimensionProblem{"width", "must not exceed the length"};
  if (auto problem = checkAreas(d)) return problem;
  if (d.centre_circle_radius >= d.width / 2.0) {
    return DimensionProblem{"centre_circle_radius", "must be less than half the field width"};
  }
  if (auto problem = checkCornerArcs(d)) return problem;
  if (d.goal_width >= d.width) {
    return DimensionProblem{"goals.width", "must be less than the field width"};
  }
  if (auto problem = checkPenaltyMarks(d)) return problem;
  return checkPenaltyArc(d);
}

}  // namespace

Vec2 LineArc::pointAt(double angle) const {
  return centre + radius * Vec2(std::cos(angle), std::sin(angle));
}

bool LineArc::contains(double angle) const {
  if (sweep >= kTwoPi) return true;
  // Offset from the start, counter-clockwise, in [0, 2*pi).
  double offset = std::fmod(angle - start_angle, kTwoPi);
  if (offset < 0.0) offset += kTwoPi;
  return offset <= sweep + kAngleTolerance || offset >= kTwoPi - kAngleTolerance;
}

std::string_view goalColourName(GoalColour colour) {
  switch (colour) {
    case GoalColour::kYellow:
      return "yellow";
    case GoalColour::kBlue:
      return "blue";
    case GoalColour::kWhite:
      return "white";
  }
  return "unknown";
}

Vec2 closestPointOnSegment(const LineSegment& segment, const Vec2& p) {
  const Vec2 direction = segment.b - segment.a;
  const double length_squared = direction.squaredNorm();
  if (length_squared <= 0.0) return segment.a;
  // Projection parameter clamped to the segment (eq. 4.74-4.75), in units of the length.
  const double t = std::clamp((p - segment.a).dot(direction) / length_squared, 0.0, 1.0);
  return segment.a + t * direction;
}

Vec2 closestPointOnArc(const LineArc& arc, const Vec2& p) {
  const Vec2 v = p - arc.centre;
  const double norm = v.norm();
  if (norm <= std::numeric_limits<double>::epsilon() * std::max(1.0, arc.radius)) {
    return arc.startPoint();
  }
  if (arc.contains(std::atan2(v.y(), v.x()))) return arc.centre + arc.radius * v / norm;
  const Vec2 start = arc.startPoint();
  const Vec2 end = arc.endPoint();
  return (p - start).squaredNorm() <= (p - end).squaredNorm() ? start : end;
}

FieldModel::FieldModel(const FieldDimensions& dimensions) : dims_(dimensions) {
  if (const auto problem = checkDimensions(dims_)) {
    throw std::invalid_argument("field '" + dims_.name + "': " + problem->key + ": " +
                                problem->what);
  }
  const double hl = dims_.length / 2.0;
  const double hw = dims_.width / 2.0;
  const double pd = dims_.penalty_area_depth;
  const double pw = dims_.penalty_area_width / 2.0;
  const double gd = dims_.goal_area_depth;
  const double gw = dims_.goal_area_width / 2.0;
  const double lw = dims_.line_width;
  const double bw = dims_.boundary_line_width;

  const auto segment = [this](double ax, double ay, double bx, double by, double width) {
    segments_.push_back(LineSegment{Vec2(ax, ay), Vec2(bx, by), width});
  };
  // Touch lines, goal lines, halfway line.
  segment(-hl, hw, hl, hw, bw);
  segment(-hl, -hw, hl, -hw, bw);
  segment(-hl, -hw, -hl, hw, bw);
  segment(hl, -hw, hl, hw, bw);
  segment(0.0, -hw, 0.0, hw, lw);
  // Front lines of the penalty and goal areas.
  if (hasPenaltyAreas()) {
    segment(-hl + pd, -pw, -hl + pd, pw, lw);
    segment(hl - pd, -pw, hl - pd, pw, lw);
  }
  if (hasGoalAreas()) {
    segment(-hl + gd, -gw, -hl + gd, gw, lw);
    segment(hl - gd, -gw, hl - gd, gw, lw);
  }
  // Side lines of the penalty area, then of the goal area: own +y, opponent +y, own -y, opp -y.
  for (const auto& [depth, half] : {std::pair{pd, pw}, std::pair{gd, gw}}) {
    if (depth <= 0.0) continue;
    segment(-hl, half, -hl + depth, half, lw);
    segment(hl - depth, half, hl, half, lw);
    segment(-hl, -half, -hl + depth, -half, lw);
    segment(hl - depth, -half, hl, -half, lw);
  }

  // Corner quarter circles, each sweeping into the field, then the centre circle.
  const double a = dims_.corner_arc_radius;
  if (hasCornerArcs()) {
    arcs_.push_back(LineArc{Vec2(-hl, hw), a, -kPi / 2.0, kPi / 2.0, lw});
    arcs_.push_back(LineArc{Vec2(hl, hw), a, kPi, kPi / 2.0, lw});
    arcs_.push_back(LineArc{Vec2(hl, -hw), a, kPi / 2.0, kPi / 2.0, lw});
    arcs_.push_back(LineArc{Vec2(-hl, -hw), a, 0.0, kPi / 2.0, lw});
  }
  if (hasCentreCircle()) {
    arcs_.push_back(LineArc{Vec2::Zero(), dims_.centre_circle_radius, 0.0, kTwoPi, lw});
  }
  if (hasPenaltyArcs()) {
    // The part of the circle in front of the front line: half-angle alpha about the axis.
    const double r = dims_.penalty_arc_radius;
    const double cd = dims_.penalty_arc_centre_distance;
    const double alpha = std::acos(std::clamp((pd - cd) / r, -1.0, 1.0));
    arcs_.push_back(LineArc{Vec2(-hl + cd, 0.0), r, -alpha, 2.0 * alpha, lw});
    arcs_.push_back(LineArc{Vec2(hl - cd, 0.0), r, kPi - alpha, 2.0 * alpha, lw});
  }

  // The goal mouth sits on the outer edge of the goal line.
  const double mouth_x = hl + bw / 2.0;
  goals_.push_back(Goal{Vec2(-mouth_x, 0.0), Vec2(-1.0, 0.0), dims_.goal_width, dims_.goal_depth,
                        dims_.goal_height, dims_.own_goal_colour});
  goals_.push_back(Goal{Vec2(mouth_x, 0.0), Vec2(1.0, 0.0), dims_.goal_width, dims_.goal_depth,
                        dims_.goal_height, dims_.opponent_goal_colour});
  if (dims_.has_penalty_marks) {
    penalty_marks_.push_back(Vec2(-hl + dims_.penalty_mark_distance, 0.0));
    penalty_marks_.push_back(Vec2(hl - dims_.penalty_mark_distance, 0.0));
  }
}

Vec2 FieldModel::carpetHalfExtent() const {
  const double outside = dims_.boundary_line_width / 2.0 + dims_.border_width;
  return Vec2(dims_.length / 2.0 + outside, dims_.width / 2.0 + outside);
}

bool FieldModel::insideLines(const Vec2& p, double margin) const {
  const double outside = dims_.boundary_line_width / 2.0 + margin;
  return std::abs(p.x()) <= dims_.length / 2.0 + outside &&
         std::abs(p.y()) <= dims_.width / 2.0 + outside;
}

FieldModel::Closest FieldModel::closestPoint(const Vec2& p) const {
  if (!p.allFinite()) throw std::invalid_argument("FieldModel::closestPoint: non-finite point");
  Closest best;
  double best_squared = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < segments_.size(); ++i) {
    const Vec2 q = closestPointOnSegment(segments_[i], p);
    const double d2 = (p - q).squaredNorm();
    if (d2 < best_squared) {
      best_squared = d2;
      best = Closest{q, 0.0, static_cast<int>(i), false};
    }
  }
  for (std::size_t i = 0; i < arcs_.size(); ++i) {
    const Vec2 q = closestPointOnArc(arcs_[i], p);
    const double d2 = (p - q).squaredNorm();
    if (d2 < best_squared) {
      best_squared = d2;
      best = Closest{q, 0.0, static_cast<int>(i), true};
    }
  }
  best.distance = std::sqrt(best_squared);
  return best;
}

std::vector<Vec2> FieldModel::sampleLines(double step) const {
  if (!(std::isfinite(step) && step > 0.0)) {
    throw std::invalid_argument("FieldModel::sampleLines: step must be positive");
  }
  std::vector<Vec2> points;
  for (const auto& s : segments_) {
    const int pieces = std::max(1, static_cast<int>(std::ceil(s.length() / step)));
    for (int k = 0; k <= pieces; ++k) {
      points.push_back(s.a + (s.b - s.a) * (static_cast<double>(k) / pieces));
    }
  }
  for (const auto& arc : arcs_) {
    // Chords are shorter than arc lengths, so spacing by arc length keeps points within `step`.
    const bool closed = arc.sweep >= kTwoPi;
    const int pieces =
        std::max(closed ? 3 : 1, static_cast<int>(std::ceil(arc.radius * arc.sweep / step)));
    const int last = closed ? pieces - 1 : pieces;
    for (int k = 0; k <= last; ++k) {
      points.push_back(arc.pointAt(arc.start_angle + arc.sweep * k / pieces));
    }
  }
  return points;
}

// --- loading ---

namespace {

GoalColour parseColour(const config::Node& node, const std::string& key) {
  const std::string name = node.getChoice(key, {"yellow", "blue", "white"});
  if (name == "yellow") return GoalColour::kYellow;
  if (name == "blue") return GoalColour::kBlue;
  return GoalColour::kWhite;
}

// The preset's optional sections, kept to name the key of a problem found after reading.
struct OptionalSections {
  std::optional<config::Node> penalty_area;
  std::optional<config::Node> goal_area;
  std::optional<config::Node> penalty_marks;
  std::optional<config::Node> penalty_arc;
};

// The field's size and lines. Optional elements: an absent key means the field does not have it.
void readLines(const config::Node& root, FieldDimensions& d) {
  d.length = root.get<double>("length", 1.0, 100.0);
  d.width = root.get<double>("width", 1.0, 100.0);
  d.line_width = root.get<double>("line_width", 0.005, 0.5);
  d.boundary_line_width = root.getOr<double>("boundary_line_width", d.line_width, 0.005, 0.5);
  d.border_width = root.get<double>("border_width", 0.0, 20.0);
  if (root.has("centre_circle_radius")) {
    d.centre_circle_radius = root.get<double>("centre_circle_radius", 0.05, 50.0);
  }
  if (root.has("corner_arc_radius")) {
    d.corner_arc_radius = root.get<double>("corner_arc_radius", 0.05, 20.0);
  }
}

// An optional area section (penalty_area, goal_area): its depth and width.
std::optional<config::Node> readArea(const config::Node& root, const std::string& key,
                                     double& depth, double& width) {
  std::optional<config::Node> area = root.childIf(key);
  if (area) {
    depth = area->get<double>("depth", 0.05, 50.0);
    width = area->get<double>("width", 0.1, 100.0);
    area->rejectUnknownKeys();
  }
  return area;
}

std::optional<config::Node> readPenaltyMarks(const config::Node& root, FieldDimensions& d) {
  std::optional<config::Node> marks = root.childIf("penalty_marks");
  if (marks) {
    d.has_penalty_marks = true;
    d.penalty_mark_distance = marks->get<double>("distance", 0.1, 50.0);
    d.penalty_mark_diameter = marks->get<double>("diameter", 0.01, 1.0);
    marks->rejectUnknownKeys();
  }
  return marks;
}

// The arc's centre defaults to the penalty mark's place.
std::optional<config::Node> readPenaltyArc(const config::Node& root, FieldDimensions& d) {
  std::optional<config::Node> penalty_arc = root.childIf("penalty_arc");
  if (penalty_arc) {
    d.penalty_arc_radius = penalty_arc->get<double>("radius", 0.05, 50.0);
    if (penalty_arc->has("centre_distance")) {
      d.penalty_arc_centre_distance = penalty_arc->get<double>("centre_distance", 0.05, 50.0);
    } else if (d.has_penalty_marks) {
      d.penalty_arc_centre_distance = d.penalty_mark_distance;
    } else {
      penalty_arc->fail("centre_distance", "required when the field has no penalty marks");
    }
    penalty_arc->rejectUnknownKeys();
  }
  return penalty_arc;
}

void readGoals(const config::Node& goals, FieldDimensions& d) {
  d.goal_width = goals.get<double>("width", 0.1, 20.0);
  d.goal_depth = goals.get<double>("depth", 0.05, 5.0);
  d.goal_height = goals.get<double>("height", 0.05, 5.0);
  d.own_goal_colour = parseColour(goals, "own_colour");
  d.opponent_goal_colour = parseColour(goals, "opponent_colour");
  goals.rejectUnknownKeys();
}

// Rulebook numbers run to the outer side of the lines (the lines belong to the areas they bound);
// moves every line inward by half its width, to its centre.
void moveLinesToCentres(FieldDimensions& d) {
  const double lw = d.line_width;
  const double bw = d.boundary_line_width;
  d.length -= bw;
  d.width -= bw;
  // Absent elements (0) stay absent.
  const auto inward = [](double& value, double by) {
    if (value > 0.0) value -= by;
  };
  inward(d.penalty_area_depth, (bw + lw) / 2.0);
  inward(d.penalty_area_width, lw);
  inward(d.goal_area_depth, (bw + lw) / 2.0);
  inward(d.goal_area_width, lw);
  inward(d.centre_circle_radius, lw / 2.0);
  inward(d.corner_arc_radius, lw / 2.0);
  inward(d.penalty_mark_distance, bw / 2.0);
  // The arc's radius runs to its outer edge, its centre from the goal line's outer edge (as the
  // penalty mark's).
  inward(d.penalty_arc_radius, lw / 2.0);
  inward(d.penalty_arc_centre_distance, bw / 2.0);
}

// Throws the problem located at its key ("section.leaf" in that section when the file has it).
[[noreturn]] void failAtKey(const DimensionProblem& problem, const config::Node& root,
                            const config::Node& goals, const OptionalSections& sections) {
  const std::string& key = problem.key;
  const auto dot = key.find('.');
  const std::string& what = problem.what;
  if (dot == std::string::npos) root.fail(key, what);
  const std::string section = key.substr(0, dot);
  const std::string leaf = key.substr(dot + 1);
  if (section == "penalty_area" && sections.penalty_area) sections.penalty_area->fail(leaf, what);
  if (section == "goal_area" && sections.goal_area) sections.goal_area->fail(leaf, what);
  if (section == "penalty_arc" && sections.penalty_arc) sections.penalty_arc->fail(leaf, what);
  if (section == "goals") goals.fail(leaf, what);
  if (section == "penalty_marks" && sections.penalty_marks)
    sections.penalty_marks->fail(leaf, what);
  root.fail(key, what);
}

}  // namespace

FieldModel loadFieldModel(const config::Node& root) {
  FieldDimensions d;
  d.name = root.get<std::string>("name");
  if (d.name.empty()) root.fail("name", "must not be empty");
  const bool outer_edges =
      root.getChoice("dimensions_measured_to", {"line_centres", "outer_edges"}) == "outer_edges";
  readLines(root, d);
  OptionalSections sections;
  sections.penalty_area =
      readArea(root, "penalty_area", d.penalty_area_depth, d.penalty_area_width);
  sections.goal_area = readArea(root, "goal_area", d.goal_area_depth, d.goal_area_width);
  sections.penalty_marks = readPenaltyMarks(root, d);
  sections.penalty_arc = readPenaltyArc(root, d);
  const config::Node goals = root.child("goals");
  readGoals(goals, d);
  root.rejectUnknownKeys();
  if (outer_edges) moveLinesToCentres(d);
  if (const auto problem = checkDimensions(d)) failAtKey(*problem, root, goals, sections);
  return FieldModel(d);
}

FieldModel loadFieldPreset(const std::string& name_or_path) {
  return loadFieldModel(config::Node::loadFile(config::resolvePreset("field", name_or_path)));
}

}  // namespace fieldline::field
