#include "services/feature_recognition/line_end_identity.hpp"

#include <algorithm>
#include <cmath>

namespace fieldline::feature_recognition {

void candidateLineEnds(const LineStructure& structure, const field::FieldModel& field,
                       const std::vector<Vec2>& taken, const RecognitionParams& params,
                       std::vector<LineEnd>& out) {
  out.clear();
  if (!structure.found) return;
  const auto& dims = field.dimensions();
  // The spacings of the penalty area's parallel lines (goal line, goal-area line, penalty-area
  // line).
  const double spacings[3] = {dims.goal_area_depth, dims.penalty_area_depth - dims.goal_area_depth,
                              dims.penalty_area_depth};
  for (int axis = 0; axis < 2; ++axis) {
    const auto& groups = structure.groups[axis];
    for (int g = 0; g < static_cast<int>(groups.size()); ++g) {
      const Line& line = groups[g].line;
      if (line.count < params.min_corner_line_points || line.length() < params.min_front_line) {
        continue;
      }
      bool partner = false;
      for (int h = 0; h < static_cast<int>(groups.size()) && !partner; ++h) {
        if (h == g || groups[h].line.count < params.min_corner_line_points) continue;
        for (double spacing : spacings) {
          if (spacing <= 0.0) continue;  // the field has no such area
          if (std::abs(std::abs(groups[h].t - groups[g].t) - spacing) <= params.spacing_tolerance) {
            partner = true;
          }
        }
      }
      if (!partner && params.line_end_alone_side_points <= 0) continue;
      // The ends of each run of the group (a line seen in parts ends where a part ends).
      for (const LineRun& run : groups[g].runs) {
        if (run.count < params.min_corner_line_points || run.length() < params.min_front_line) {
          continue;
        }
        for (int side = 0; side < 2; ++side) {
          LineEnd end;
          end.position = line.centre + (side == 0 ? run.t_min : run.t_max) * line.direction;
          end.into = side == 0 ? line.direction : Vec2(-line.direction);
          end.length = run.length();
          end.axis = axis;
          end.group = g;
          end.partner = partner;
          if (end.position.norm() > params.line_end_range) continue;
          const bool explained = std::any_of(taken.begin(), taken.end(), [&](const Vec2& t) {
            return (t - end.position).norm() < params.junction_distance;
          });
          if (!explained) out.push_back(end);
        }
      }
    }
  }
}

int pointsAlong(const std::vector<Vec2>& points, const Vec2& from, const Vec2& direction,
                double reach) {
  int count = 0;
  for (const Vec2& p : points) {
    const Vec2 d = p - from;
    const double t = d.dot(direction);
    if (t < 0.1 || t > reach) continue;
    if (std::abs(direction.x() * d.y() - direction.y() * d.x()) <= 0.1 + 0.02 * p.norm()) ++count;
  }
  return count;
}

int pointsOffLegs(const std::vector<Vec2>& points, const Vec2& corner,
                  const std::vector<Vec2>& legs, double from, double reach) {
  int count = 0;
  for (const Vec2& p : points) {
    const Vec2 d = p - corner;
    const double r = d.norm();
    if (r < from || r > reach) continue;
    const double tolerance = 0.1 + 0.02 * p.norm();
    const bool on_leg = std::any_of(legs.begin(), legs.end(), [&](const Vec2& leg) {
      return d.dot(leg) >= 0.0 && std::abs(leg.x() * d.y() - leg.y() * d.x()) <= tolerance;
    });
    if (!on_leg) ++count;
  }
  return count;
}

namespace {

// The model junction's legs turned into the frame of a robot with heading `phi`.
void legsInRobotFrame(const ModelJunction& model, double phi, std::vector<Vec2>& legs) {
  legs.clear();
  for (const Vec2& leg : model.legs)
    legs.push_back(geometry::rotate(leg, -phi));
}

// Screening: the best share of the other points fitting the pose that puts the line along a leg
// of a model penalty corner (on a few of the points).
double screenLineEnd(const LineEnd& end, double end_phi, const std::vector<ModelJunction>& models,
                     const std::vector<Vec2>& others, const ModelCheck& check,
                     const RecognitionParams& params) {
  double best_screen = 0.0;
  for (const ModelJunction& model : models) {
    if (!model.penalty_corner) continue;
    for (std::size_t l = 0; l < model.legs.size(); ++l) {
      if (end.length > model.leg_lengths[l] + params.length_tolerance) continue;
      const double phi = model.leg_angles[l] - end_phi;
      const Vec2 robot = model.position - geometry::rotate(end.position, phi);
      const geometry::Pose2 pose{robot.x(), robot.y(), geometry::normalizeAngle(phi)};
      best_screen =
          std::max(best_screen, check.fit(others, pose, params.line_end_screen_points).share());
    }
  }
  return best_screen;
}

// The best share of the other points with the pose shifted each way along and across the line:
// the position must be fixed by them (a perpendicular line among them fixes it along the line,
// a parallel one across it).
double shiftedShare(const std::vector<Vec2>& others, const geometry::Pose2& robot,
                    const Vec2& along, const ModelCheck& check, const RecognitionParams& params) {
  double best = 0.0;
  const Vec2 across(-along.y(), along.x());
  for (const Vec2& direction : {along, across}) {
    for (double sign : {-1.0, 1.0}) {
      const Vec2 shifted = robot.position() + sign * params.line_end_shift * direction;
      const geometry::Pose2 pose{shifted.x(), shifted.y(), robot.phi};
      best = std::max(best, check.fit(others, pose).share());
    }
  }
  return best;
}

// The verdict on an identified line end's evidence.
bool lineEndIdentified(const LineEndIdentity& out, bool partner, const RecognitionParams& params) {
  const double share = out.identity.fit.share();
  return out.identity.fit.points >= params.identity_min_points &&
         share >= params.identity_min_share &&
         out.identity.rival_share <= share - params.identity_margin &&
         out.shifted_share <= share - params.line_end_shift_margin &&
         out.side_points >=
             (partner ? params.line_end_min_side_points : params.line_end_alone_side_points) &&
         (params.line_end_max_beyond_points < 0 ||
          out.beyond_points <= params.line_end_max_beyond_points);
}

}  // namespace

int pointsOffJunction(const std::vector<Vec2>& points, const ModelJunction& model,
                      const geometry::Pose2& robot, double from, double reach) {
  thread_local std::vector<Vec2> legs;
  legsInRobotFrame(model, robot.phi, legs);
  return pointsOffLegs(points, geometry::pointFieldToRobot(robot, model.position), legs, from,
                       reach);
}

bool identifyLineEnd(const LineEnd& end, const std::vector<ModelJunction>& models,
                     const std::vector<Vec2>& points, const ModelCheck& check,
                     const RecognitionParams& params, LineEndIdentity& out) {
  out = {};
  Junction junction;
  junction.position = end.position;
  junction.phi = std::atan2(end.into.y(), end.into.x());
  junction.leg_count = 1;
  junction.legs = {end.into, Vec2::Zero(), Vec2::Zero()};
  junction.leg_lengths = {end.length, 0.0, 0.0};
  // The other points: those not on the line.
  thread_local std::vector<Vec2> others;
  others.clear();
  const Vec2 far_end = end.position + end.length * end.into;
  pointsAwayFrom(points, {{end.position, far_end}}, params.identity_leg_margin, others);
  if (static_cast<int>(others.size()) < params.identity_min_points) return false;
  const double best_screen = screenLineEnd(end, junction.phi, models, others, check, params);
  if (best_screen < params.identity_min_share - params.identity_screen_slack) return false;
  // The verdict is taken below, on the refined pose (identifyJunction's own is on the line's
  // last point).
  identifyJunction(junction, models, points, check, params, out.identity);
  if (out.identity.model < 0) return false;
  // The pose along the line from the other points (the perpendicular lines among them): the
  // line's last point is up to a sample spacing short of the true end.
  const geometry::Pose2 first = out.identity.robot;
  const Vec2 along = geometry::rotate(end.into, first.phi);
  const double refined = check.refineShift(others, first, along, params.line_end_shift / 2);
  const geometry::Pose2 robot{first.x + refined * along.x(), first.y + refined * along.y(),
                              first.phi};
  out.identity.robot = robot;
  out.identity.fit = check.fit(others, robot);
  out.corner = geometry::pointFieldToRobot(robot, models[out.identity.model].position);
  out.shifted_share = shiftedShare(others, robot, along, check, params);
  // Evidence of the corner's other line: a few points where the model puts it (across the seen
  // line, where the model's other leg runs).
  const ModelJunction& model = models[out.identity.model];
  thread_local std::vector<Vec2> legs;
  legsInRobotFrame(model, robot.phi, legs);
  for (std::size_t l = 0; l < legs.size(); ++l) {
    if (std::abs(legs[l].dot(end.into)) > 0.5) continue;  // the seen line's own leg
    out.side_points += pointsAlong(points, out.corner, legs[l],
                                   std::min(params.line_end_side_reach, model.leg_lengths[l]));
  }
  // An L, not a T or a bend: around the corner (line_end_side_reach), off the model's legs, the
  // points must show nothing either. At a penalty corner both lines end there; at the halfway
  // line's end the touch line runs on to both sides, and a flat piece of the centre circle that
  // looks like a line ending goes on curving away from its "corner".
  out.beyond_points = pointsOffLegs(points, out.corner, legs, params.line_end_beyond_from,
                                    params.line_end_side_reach);
  out.identified = lineEndIdentified(out, end.partner, params);
  return out.identified;
}

}  // namespace fieldline::feature_recognition
