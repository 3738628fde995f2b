#include "services/feature_recognition/junction_identity.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace fieldline::feature_recognition {

namespace {

constexpr double kPi = std::numbers::pi;

// Distance of p from the segment from a along unit `dir` over `length`.
double distanceToLeg(const Vec2& p, const Vec2& a, const Vec2& dir, double length) {
  const double t = std::clamp((p - a).dot(dir), 0.0, length);
  return (p - (a + t * dir)).norm();
}

// True if the poses are each other or point-symmetric twins (within the eval's false limits,
// much tighter than the spacing of the field's junctions).
bool sameOrTwin(const geometry::Pose2& a, const geometry::Pose2& b) {
  const double same = (a.position() - b.position()).norm();
  const double twin = (a.position() + b.position()).norm();
  const double same_angle = std::abs(geometry::angleDiff(a.phi, b.phi));
  const double twin_angle = std::abs(geometry::angleDiff(a.phi + kPi, b.phi));
  return (same < 0.3 && same_angle < 0.1) || (twin < 0.3 && twin_angle < 0.1);
}

}  // namespace

std::vector<ModelJunction> modelJunctions(const field::FieldModel& field) {
  std::vector<ModelJunction> out;
  const auto& segs = field.segments();
  const auto& d = field.dimensions();
  constexpr double kEps = 1e-6;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    for (std::size_t j = i + 1; j < segs.size(); ++j) {
      const Vec2 ui = (segs[i].b - segs[i].a).normalized();
      const Vec2 uj = (segs[j].b - segs[j].a).normalized();
      if (std::abs(ui.dot(uj)) > 1e-6) continue;  // only perpendicular lines meet on a field
      // Intersection of the two lines.
      const double cross = ui.x() * uj.y() - ui.y() * uj.x();
      const Vec2 w = segs[j].a - segs[i].a;
      const double s = (w.x() * uj.y() - w.y() * uj.x()) / cross;
      const Vec2 x = segs[i].a + s * ui;
      const double si = (x - segs[i].a).dot(ui), sj = (x - segs[j].a).dot(uj);
      if (si < -kEps || si > segs[i].length() + kEps || sj < -kEps ||
          sj > segs[j].length() + kEps) {
        continue;
      }
      ModelJunction m;
      m.position = x;
      auto addLegs = [&](const field::LineSegment& seg, const Vec2& u, double at) {
        if (at > kEps) {
          m.legs.push_back(-u);
          m.leg_lengths.push_back(at);
        }
        if (seg.length() - at > kEps) {
          m.legs.push_back(u);
          m.leg_lengths.push_back(seg.length() - at);
        }
      };
      addLegs(segs[i], ui, si);
      addLegs(segs[j], uj, sj);
      // The corners of the penalty and goal areas.
      for (int inner = 0; inner < 2; ++inner) {
        if (!(inner ? field.hasGoalAreas() : field.hasPenaltyAreas())) continue;
        const double cx = field.length() / 2 - (inner ? d.goal_area_depth : d.penalty_area_depth);
        const double cy = (inner ? d.goal_area_width : d.penalty_area_width) / 2;
        if (m.legs.size() == 2 && std::abs(std::abs(x.x()) - cx) < 1e-6 &&
            std::abs(std::abs(x.y()) - cy) < 1e-6) {
          m.penalty_corner = true;
          m.inner = inner != 0;
          // Looking toward the opponent goal (+x) left is +y; the own goal is the reflection.
          m.left = x.x() > 0 ? x.y() > 0 : x.y() < 0;
          m.toward_goal = Vec2(x.x() > 0 ? 1.0 : -1.0, 0.0);
        }
      }
      for (const Vec2& leg : m.legs)
        m.leg_angles.push_back(std::atan2(leg.y(), leg.x()));
      out.push_back(m);
    }
  }
  return out;
}

bool identifyJunction(const Junction& junction, const std::vector<ModelJunction>& models,
                      const std::vector<Vec2>& points, const ModelCheck& check,
                      const RecognitionParams& params, JunctionIdentity& out) {
  if (junction.leg_count < 1) return false;
  // The other points: those not on the junction's own lines.
  thread_local std::vector<Vec2> others;
  others.clear();
  for (const Vec2& p : points) {
    bool on_leg = false;
    for (int k = 0; k < junction.leg_count && !on_leg; ++k) {
      on_leg = distanceToLeg(p, junction.position, junction.legs[k], junction.leg_lengths[k]) <
               params.identity_leg_margin;
    }
    if (!on_leg) others.push_back(p);
  }
  const double min_cos = std::cos(params.identity_angle);
  const Vec2& o0 = junction.legs[0];
  const double o0_angle = std::atan2(o0.y(), o0.x());
  struct Candidate {
    int model;
    geometry::Pose2 robot;
    ModelFit fit;
  };
  thread_local std::vector<Candidate> candidates;
  candidates.clear();
  for (std::size_t m = 0; m < models.size(); ++m) {
    const ModelJunction& model = models[m];
    // An L may be a T with one half of its bar unseen; a T is only a T.
    if (static_cast<int>(model.legs.size()) < junction.leg_count) continue;
    for (const double first_angle : model.leg_angles) {
      const double phi = first_angle - o0_angle;
      bool fits = true;
      for (int k = 0; k < junction.leg_count && fits; ++k) {
        const Vec2 leg = geometry::rotate(junction.legs[k], phi);
        fits = false;
        for (std::size_t l = 0; l < model.legs.size(); ++l) {
          if (leg.dot(model.legs[l]) > min_cos &&
              junction.leg_lengths[k] <= model.leg_lengths[l] + params.length_tolerance) {
            fits = true;
          }
        }
      }
      if (!fits) continue;
      const Vec2 robot = model.position - geometry::rotate(junction.position, phi);
      const geometry::Pose2 pose{robot.x(), robot.y(), geometry::normalizeAngle(phi)};
      candidates.push_back(
          {static_cast<int>(m), pose, check.fit(others, pose, params.identity_screen_points)});
    }
  }
  if (candidates.empty()) return false;
  const auto best = std::max_element(
      candidates.begin(), candidates.end(),
      [](const Candidate& a, const Candidate& b) { return a.fit.share() < b.fit.share(); });
  // The chosen place on all the other points (the screening used a thinned set), and so is every
  // rival the screening puts near it: the verdict rests on full fits wherever it is close.
  const ModelFit chosen = check.fit(others, best->robot);
  double rival = 0.0;
  for (const Candidate& c : candidates) {
    if (sameOrTwin(c.robot, best->robot)) continue;
    double share = c.fit.share();
    if (share > chosen.share() - params.identity_margin - params.identity_screen_slack) {
      share = check.fit(others, c.robot).share();
    }
    rival = std::max(rival, share);
  }
  out.model = best->model;
  out.robot = best->robot;
  out.fit = chosen;
  out.rival_share = rival;
  return chosen.points >= params.identity_min_points &&
         chosen.share() >= params.identity_min_share &&
         rival <= chosen.share() - params.identity_margin;
}

}  // namespace fieldline::feature_recognition
