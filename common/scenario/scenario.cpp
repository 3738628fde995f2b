#include "common/scenario/scenario.hpp"

#include <algorithm>
#include <numbers>
#include <set>

namespace fieldline::scenario {
namespace {

constexpr double kMaxCoordinate = 50.0;

// An optional list that is absent (or null): mark the key as known for rejectUnknownKeys().
void markOptional(const config::Node& n, const std::string& key) {
  n.childIf(key);
}

geometry::Vec2 readPoint(const config::Node& n) {
  const geometry::Vec2 p(n.get<double>("x", -kMaxCoordinate, kMaxCoordinate),
                         n.get<double>("y", -kMaxCoordinate, kMaxCoordinate));
  n.rejectUnknownKeys();
  return p;
}

geometry::Pose2 readPose(const config::Node& n) {
  geometry::Pose2 p;
  p.x = n.get<double>("x", -kMaxCoordinate, kMaxCoordinate);
  p.y = n.get<double>("y", -kMaxCoordinate, kMaxCoordinate);
  p.phi = n.getOr<double>("phi", 0.0, -2.0 * std::numbers::pi, 2.0 * std::numbers::pi);
  n.rejectUnknownKeys();
  return p;
}

robot::TrajectorySpec readTrajectory(const config::Node& n) {
  const std::string type =
      n.getChoice("type", {"figure_eight", "waypoints", "rotate", "stand", "random"});
  robot::TrajectorySpec out;
  if (type == "figure_eight") {
    robot::FigureEightSpec s;
    if (auto c = n.childIf("center")) s.center = readPoint(*c);
    s.length = n.get<double>("length", 0.1, 40.0);
    s.width = n.get<double>("width", 0.1, 30.0);
    s.rotation = n.getOr<double>("rotation", 0.0, -2.0 * std::numbers::pi, 2.0 * std::numbers::pi);
    s.speed = n.get<double>("speed", 0.0, 5.0);
    out = s;
  } else if (type == "waypoints") {
    robot::WaypointSpec s;
    for (const auto& p : n.children("points"))
      s.points.push_back(readPoint(p));
    if (s.points.empty()) n.fail("points", "needs at least one point");
    s.speed = n.get<double>("speed", 0.01, 5.0);
    s.loop = n.getOr<bool>("loop", true);
    s.face_along_path = n.getOr<bool>("face_along_path", true);
    out = s;
  } else if (type == "rotate") {
    out = robot::RotateSpec{n.get<double>("omega", -20.0, 20.0)};
  } else if (type == "stand") {
    out = robot::StandSpec{};
  } else {
    robot::RandomPlaySpec s;
    s.half_length = n.get<double>("half_length", 0.1, 25.0);
    s.half_width = n.get<double>("half_width", 0.1, 25.0);
    s.speed = n.get<double>("speed", 0.01, 5.0);
    s.seed = static_cast<std::uint64_t>(n.get<std::int64_t>("seed", 0, INT64_MAX));
    out = s;
  }
  n.rejectUnknownKeys();
  return out;
}

// The list at `key` of the root, or none when it is absent (or null).
std::vector<config::Node> optionalList(const config::Node& root, const std::string& key) {
  if (root.has(key)) return root.children(key);
  markOptional(root, key);
  return {};
}

// The team's robots, each with a distinct id; `ids` gets those ids.
std::vector<RobotSpec> readRobots(const config::Node& root, std::set<int>& ids) {
  std::vector<RobotSpec> robots;
  for (const auto& r : root.children("robots")) {
    RobotSpec spec;
    spec.id = r.get<int>("id", 1, 6);
    if (!ids.insert(spec.id).second) r.fail("id", "robot " + std::to_string(spec.id) + " twice");
    const auto trajectory = r.child("trajectory");
    spec.trajectory = readTrajectory(trajectory);
    if (auto start = r.childIf("start")) {
      spec.start = readPose(*start);
    } else if (std::holds_alternative<robot::FigureEightSpec>(spec.trajectory)) {
      spec.start = robot::Trajectory(spec.trajectory, {}).startPose();
    } else {
      r.fail("start", "missing required section (only a figure eight knows its own start)");
    }
    r.rejectUnknownKeys();
    robots.push_back(spec);
  }
  if (robots.empty()) root.fail("robots", "needs at least one robot");
  return robots;
}

OpponentSpec readOpponent(const config::Node& o) {
  OpponentSpec spec;
  spec.start = readPose(o.child("start"));
  spec.trajectory = readTrajectory(o.child("trajectory"));
  spec.radius = o.getOr<double>("radius", 0.25, 0.05, 1.0);
  o.rejectUnknownKeys();
  return spec;
}

BallKick readKick(const config::Node& k) {
  BallKick kick;
  kick.time = k.get<double>("time", 0.0, 1e6);
  if (auto p = k.childIf("position")) kick.position = readPoint(*p);
  kick.velocity = readPoint(k.child("velocity"));
  if (kick.velocity.norm() > 15.0) k.fail("velocity", "faster than 15 m/s");
  k.rejectUnknownKeys();
  return kick;
}

void readBall(const config::Node& ball, BallSpec& out) {
  if (auto start = ball.childIf("start")) out.start = readPoint(*start);
  out.radius = ball.getOr<double>("radius", 0.11, 0.01, 0.5);
  out.rolling_deceleration = ball.getOr<double>("rolling_deceleration", 0.4, 0.0, 10.0);
  out.restitution = ball.getOr<double>("restitution", 0.6, 0.0, 1.0);
  if (ball.has("kicks")) {
    for (const auto& k : ball.children("kicks"))
      out.kicks.push_back(readKick(k));
  }
  ball.rejectUnknownKeys();
}

// The id of the scenario's robot an event names.
int eventRobot(const config::Node& n, const std::set<int>& ids) {
  const int id = n.get<int>("robot", 1, 6);
  if (!ids.count(id)) n.fail("robot", "no robot " + std::to_string(id) + " in this scenario");
  return id;
}

KidnapSpec readKidnap(const config::Node& k, const std::set<int>& ids) {
  KidnapSpec spec;
  spec.time = k.get<double>("time", 0.0, 1e6);
  spec.robot = eventRobot(k, ids);
  spec.pose = readPose(k.child("pose"));
  k.rejectUnknownKeys();
  return spec;
}

SerialOutageSpec readSerialOutage(const config::Node& o, const std::set<int>& ids) {
  SerialOutageSpec spec;
  spec.time = o.get<double>("time", 0.0, 1e6);
  spec.robot = eventRobot(o, ids);
  spec.duration = o.get<double>("duration", 0.01, 1e4);
  o.rejectUnknownKeys();
  return spec;
}

}  // namespace

const RobotSpec* Scenario::robotById(int id) const {
  for (const auto& r : robots) {
    if (r.id == id) return &r;
  }
  return nullptr;
}

Scenario loadScenario(const config::Node& root) {
  Scenario s;
  s.name = root.get<std::string>("name");
  s.field = root.getOr<std::string>("field", "msl");
  s.robot = root.getOr<std::string>("robot", "fu2004");
  s.duration = root.getOr<double>("duration", 0.0, 0.0, 1e6);
  s.seed = static_cast<std::uint64_t>(root.get<std::int64_t>("seed", 0, INT64_MAX));
  s.physics_rate = root.getOr<double>("physics_rate", 400.0, 200.0, 10000.0);
  s.slip_scale = root.getOr<double>("slip_scale", 1.0, 0.0, 10.0);
  std::set<int> ids;
  s.robots = readRobots(root, ids);
  for (const auto& o : optionalList(root, "opponents"))
    s.opponents.push_back(readOpponent(o));
  if (auto ball = root.childIf("ball")) readBall(*ball, s.ball);
  for (const auto& k : optionalList(root, "kidnaps"))
    s.kidnaps.push_back(readKidnap(k, ids));
  for (const auto& o : optionalList(root, "serial_outages"))
    s.serial_outages.push_back(readSerialOutage(o, ids));
  root.rejectUnknownKeys();
  return s;
}

Scenario loadScenarioPreset(const std::string& name_or_path) {
  return loadScenario(config::Node::loadFile(config::resolvePreset("scenarios", name_or_path)));
}

}  // namespace fieldline::scenario
