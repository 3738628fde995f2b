#include "services/world_sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "services/world_sim/world_snapshot.hpp"

namespace fieldline::world_sim {
namespace {

// The scenario scales the robot's systematic errors and noise (0: an exact robot).
robot::RobotParams scaledParams(robot::RobotParams p, double scale) {
  for (auto& e : p.simulation.wheel_radius_error)
    e *= scale;
  for (auto& e : p.simulation.wheel_angle_error)
    e *= scale;
  p.simulation.slip_noise *= scale;
  p.simulation.rotation_noise *= scale;
  p.simulation.collision_rotation_noise *= scale;
  return p;
}

// Pushes a moving ball out of a circle moving with `obstacle_velocity` and reflects its
// relative normal speed. True if they touched.
bool bounceOffCircle(BallTruth& ball, const geometry::Vec2& centre, double radius,
                     const geometry::Vec2& obstacle_velocity, double restitution) {
  const geometry::Vec2 offset = ball.position - centre;
  const double reach = radius + ball.radius;
  const double d = offset.norm();
  if (d >= reach) return false;
  const geometry::Vec2 normal = d > 1e-9 ? geometry::Vec2(offset / d) : geometry::Vec2(1.0, 0.0);
  ball.position = centre + normal * reach;
  geometry::Vec2 relative = ball.velocity - obstacle_velocity;
  const double vn = relative.dot(normal);
  if (vn < 0.0) relative -= (1.0 + restitution) * vn * normal;
  ball.velocity = relative + obstacle_velocity;
  return true;
}

}  // namespace

World::World(const scenario::Scenario& scenario)
    : World(scenario, robot::loadRobotPreset(scenario.robot),
            field::loadFieldPreset(scenario.field)) {}

World::World(const scenario::Scenario& scenario, const robot::RobotParams& params,
             const field::FieldModel& field)
    : scenario_(scenario),
      params_(scaledParams(params, scenario.slip_scale)),
      field_(field),
      dt_(1.0 / scenario.physics_rate),
      nominal_(params_.wheels),
      true_(params_.trueWheels()),
      motor_(robot::MotorModel::fromParams(params_)),
      barrier_(field.carpetHalfExtent()),
      rng_(scenario.seed) {
  if (scenario.physics_rate < 200.0) throw std::invalid_argument("world: physics below 200 Hz");
  const int wheels = params_.wheelCount();
  radius_scale_.resize(wheels);
  for (int i = 0; i < wheels; ++i) {
    radius_scale_[i] = 1.0 + params_.simulation.wheel_radius_error[static_cast<std::size_t>(i)];
  }
  for (const auto& spec : scenario.robots) {
    RobotTruth r;
    r.id = spec.id;
    r.pose = spec.start;
    r.wheel_commands = robot::WheelVector::Zero(wheels);
    r.wheel_speeds = robot::WheelVector::Zero(wheels);
    r.wheel_angles = robot::WheelVector::Zero(wheels);
    r.wheel_slip = robot::WheelVector::Zero(wheels);
    robots_.push_back(r);
  }
  previous_poses_.resize(robots_.size());
  surface_travel_.assign(robots_.size(), robot::WheelVector::Zero(wheels));
  for (const auto& o : scenario.opponents) {
    opponent_paths_.emplace_back(o.trajectory, o.start);
    opponents_.push_back({opponent_paths_.back().at(0.0).pose, o.radius});
  }
  ball_.position = scenario.ball.start;
  ball_.radius = scenario.ball.radius;
  kicks_ = scenario.ball.kicks;
  std::stable_sort(
      kicks_.begin(), kicks_.end(),
      [](const scenario::BallKick& a, const scenario::BallKick& b) { return a.time < b.time; });
  kidnaps_ = scenario.kidnaps;
  std::stable_sort(
      kidnaps_.begin(), kidnaps_.end(),
      [](const scenario::KidnapSpec& a, const scenario::KidnapSpec& b) { return a.time < b.time; });
}

int World::indexOf(int id) const {
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    if (robots_[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

void World::setWheelCommands(std::size_t index, const robot::WheelVector& commands) {
  auto& c = robots_.at(index).wheel_commands;
  if (commands.size() != c.size()) {
    throw std::invalid_argument("world: " + std::to_string(commands.size()) +
                                " wheel commands for " + std::to_string(c.size()) + " wheels");
  }
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    c[i] = std::isfinite(commands[i]) ? std::clamp(commands[i], -1.0, 1.0) : 0.0;
  }
}

void World::setCommand(std::size_t index, const robot::NormalizedCommand& command) {
  setWheelCommands(index, robot::wheelCommands(command, params_, nominal_));
}

robot::TickCounts World::ticks(std::size_t index) const {
  const auto& angles = robots_.at(index).wheel_angles;
  const double per_radian = params_.ticksPerWheelRevolution() / (2.0 * std::numbers::pi);
  robot::TickCounts out;
  for (Eigen::Index i = 0; i < angles.size(); ++i) {
    const auto count = static_cast<std::int64_t>(std::floor(angles[i] * per_radian));
    out.push_back(static_cast<std::int32_t>(static_cast<std::uint32_t>(count & 0xffffffffLL)));
  }
  return out;
}

void World::kidnap(std::size_t index, const geometry::Pose2& pose) {
  auto& r = robots_.at(index);
  r.pose = pose;
  r.pose.phi = geometry::normalizeAngle(pose.phi);
  previous_poses_[index] = r.pose;
  ++r.kidnaps;
}

WorldSnapshot World::snapshot() const {
  WorldSnapshot s;
  s.scenario = scenario_.name;
  s.steps = steps_;
  s.next_kick = next_kick_;
  s.next_kidnap = next_kidnap_;
  s.ball = ball_;
  s.robots = robots_;
  std::ostringstream rng;
  rng << rng_;
  s.rng = rng.str();
  return s;
}

void World::restore(const WorldSnapshot& s) {
  if (s.scenario != scenario_.name) {
    throw std::invalid_argument("snapshot of scenario '" + s.scenario + "', not '" +
                                scenario_.name + "'");
  }
  if (s.robots.size() != robots_.size()) {
    throw std::invalid_argument("snapshot has " + std::to_string(s.robots.size()) +
                                " robots, the scenario " + std::to_string(robots_.size()));
  }
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    const auto wheels = static_cast<Eigen::Index>(params_.wheelCount());
    const RobotTruth& r = s.robots[i];
    if (r.wheel_commands.size() != wheels || r.wheel_speeds.size() != wheels ||
        r.wheel_angles.size() != wheels) {
      throw std::invalid_argument("snapshot robot " + std::to_string(r.id) + " has " +
                                  std::to_string(r.wheel_angles.size()) + " wheels, the robot " +
                                  std::to_string(wheels));
    }
    if (s.robots[i].id != robots_[i].id) {
      throw std::invalid_argument("snapshot robot " + std::to_string(s.robots[i].id) +
                                  " where the scenario has robot " + std::to_string(robots_[i].id));
    }
  }
  if (s.next_kick > kicks_.size() || s.next_kidnap > kidnaps_.size() || s.steps < 0) {
    throw std::invalid_argument("snapshot events or time out of range");
  }
  std::mt19937_64 rng;
  std::istringstream rng_text(s.rng);
  rng_text >> rng;
  if (rng_text.fail()) throw std::invalid_argument("snapshot: unreadable random engine state");
  rng_ = rng;
  normal_.reset();
  steps_ = s.steps;
  next_kick_ = s.next_kick;
  next_kidnap_ = s.next_kidnap;
  const double radius = ball_.radius;
  ball_ = s.ball;
  ball_.radius = radius;
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    robots_[i] = s.robots[i];
    // The slip is not in a snapshot: it starts over at zero.
    if (robots_[i].wheel_slip.size() != robots_[i].wheel_angles.size())
      robots_[i].wheel_slip = robot::WheelVector::Zero(robots_[i].wheel_angles.size());
    previous_poses_[i] = robots_[i].pose;
  }
  for (std::size_t k = 0; k < opponents_.size(); ++k)
    opponents_[k].pose = opponent_paths_[k].at(time()).pose;
}

void World::applyEvents() {
  const double t = time();
  while (next_kick_ < kicks_.size() && kicks_[next_kick_].time <= t) {
    const auto& k = kicks_[next_kick_++];
    if (k.position) ball_.position = *k.position;
    ball_.velocity = k.velocity;
  }
  while (next_kidnap_ < kidnaps_.size() && kidnaps_[next_kidnap_].time <= t) {
    const auto& k = kidnaps_[next_kidnap_++];
    const int index = indexOf(k.robot);
    if (index >= 0) kidnap(static_cast<std::size_t>(index), k.pose);
  }
}

void World::stepRobot(std::size_t index) {
  auto& r = robots_[index];
  const auto& sim = params_.simulation;
  // Exact integral of the first-order wheel response over the step.
  const double tau = motor_.timeConstant();
  const double decay = std::exp(-dt_ / tau);
  const robot::WheelVector target = r.wheel_commands * (motor_.alpha() / motor_.beta());
  const robot::WheelVector travel = target * dt_ + (r.wheel_speeds - target) * tau * (1.0 - decay);
  r.wheel_speeds = target + (r.wheel_speeds - target) * decay;
  const Eigen::Index wheels = travel.size();
  for (Eigen::Index i = 0; i < wheels; ++i) {
    r.wheel_angles[i] += travel[i] / params_.wheels[static_cast<std::size_t>(i)].radius;
  }

  // What the floor makes of it: true radii, slip noise per wheel (white, so the error of a
  // wheel's path grows with the square root of time), then the true geometry.
  const double noise_scale = sim.slip_noise / std::sqrt(dt_);
  // More wheels than the body's three degrees of freedom fight each other: the body moves by the
  // twist that fits their contact travel best (least squares), and each wheel slips by the rest
  // (wheel_slip below).
  robot::WheelVector contact(wheels);
  for (Eigen::Index i = 0; i < wheels; ++i) {
    surface_travel_[index][i] = travel[i] * radius_scale_[i];
    contact[i] = surface_travel_[index][i] * (1.0 + noise_scale * normal_(rng_));
  }
  Eigen::Vector3d body = true_.robotMatrixInverse() * contact;
  const double speed = std::hypot(body.x(), body.y()) / dt_;
  body.z() += sim.rotation_noise * speed * std::sqrt(dt_) * normal_(rng_);
  if (r.in_contact) body.z() += sim.collision_rotation_noise * std::sqrt(dt_) * normal_(rng_);
  r.pose = geometry::applyMovement(r.pose, robot::arcMovement(body));
}

void World::resolveCollisions() {
  const double radius = params_.radius;
  for (auto& r : robots_) {
    r.in_contact = false;
    const double lx = barrier_.x() - radius;
    const double ly = barrier_.y() - radius;
    if (std::abs(r.pose.x) > lx || std::abs(r.pose.y) > ly) {
      r.pose.x = std::clamp(r.pose.x, -lx, lx);
      r.pose.y = std::clamp(r.pose.y, -ly, ly);
      r.in_contact = true;
    }
    for (const auto& o : opponents_) {
      const geometry::Vec2 offset = r.pose.position() - o.pose.position();
      const double reach = radius + o.radius;
      const double d = offset.norm();
      if (d < reach) {
        const geometry::Vec2 n = d > 1e-9 ? geometry::Vec2(offset / d) : geometry::Vec2(1.0, 0.0);
        const geometry::Vec2 p = o.pose.position() + n * reach;
        r.pose.x = p.x();
        r.pose.y = p.y();
        r.in_contact = true;
      }
    }
  }
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    for (std::size_t j = i + 1; j < robots_.size(); ++j) {
      auto& a = robots_[i];
      auto& b = robots_[j];
      const geometry::Vec2 offset = a.pose.position() - b.pose.position();
      const double d = offset.norm();
      if (d >= 2.0 * radius) continue;
      const geometry::Vec2 n = d > 1e-9 ? geometry::Vec2(offset / d) : geometry::Vec2(1.0, 0.0);
      const geometry::Vec2 push = n * (0.5 * (2.0 * radius - d));
      a.pose.x += push.x();
      a.pose.y += push.y();
      b.pose.x -= push.x();
      b.pose.y -= push.y();
      a.in_contact = b.in_contact = true;
    }
  }
}

void World::stepBall() {
  const double e = scenario_.ball.restitution;
  ball_.position += ball_.velocity * dt_;
  const double speed = ball_.velocity.norm();
  if (speed > 0.0) {
    const double slower = std::max(0.0, speed - scenario_.ball.rolling_deceleration * dt_);
    ball_.velocity *= slower / speed;
  }
  for (int axis = 0; axis < 2; ++axis) {
    const double limit = barrier_[axis] - ball_.radius;
    if (std::abs(ball_.position[axis]) > limit) {
      ball_.position[axis] = std::copysign(limit, ball_.position[axis]);
      if (ball_.velocity[axis] * ball_.position[axis] > 0.0) ball_.velocity[axis] *= -e;
    }
  }
  for (auto& r : robots_) {
    if (bounceOffCircle(ball_, r.pose.position(), params_.radius, r.velocity, e)) {
      r.in_contact = true;
    }
  }
  for (std::size_t k = 0; k < opponents_.size(); ++k) {
    const geometry::Vec2 v = opponent_paths_[k].at(time()).velocity;
    bounceOffCircle(ball_, opponents_[k].pose.position(), opponents_[k].radius, v, e);
  }
}

void World::step() {
  applyEvents();
  for (std::size_t k = 0; k < opponents_.size(); ++k) {
    opponents_[k].pose = opponent_paths_[k].at(time() + dt_).pose;
  }
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    previous_poses_[i] = robots_[i].pose;
    stepRobot(i);
  }
  resolveCollisions();
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    auto& r = robots_[i];
    r.pose.phi = geometry::normalizeAngle(r.pose.phi);
    r.velocity = (r.pose.position() - previous_poses_[i].position()) / dt_;
    r.omega = geometry::angleDiff(r.pose.phi, previous_poses_[i].phi) / dt_;
    // The body's movement over the step in its frame at the step's start, at each wheel.
    const geometry::Pose2& before = previous_poses_[i];
    const double c = std::cos(before.phi);
    const double s = std::sin(before.phi);
    const double dx = r.pose.x - before.x;
    const double dy = r.pose.y - before.y;
    const Eigen::Vector3d body(c * dx + s * dy, -s * dx + c * dy, r.omega * dt_);
    r.wheel_slip += surface_travel_[i] - true_.robotMatrix() * body;
  }
  stepBall();
  for (auto& r : robots_)
    r.contact_steps += r.in_contact ? 1 : 0;
  ++steps_;
  // The normal distribution draws in pairs and keeps the second: a step with an odd number of
  // draws (four wheels, a collision's twist) would carry it into the next, which a snapshot (the
  // engine's state only) cannot restore. Dropped at every step's end, so a restored world goes on
  // bit for bit; with an even number of draws nothing is kept and nothing changes.
  normal_.reset();
}

void World::runUntil(double t) {
  while (time() < t - 1e-12)
    step();
}

}  // namespace fieldline::world_sim
