#include "common/msg/world_state.hpp"

#include <algorithm>

namespace fieldline::msg {

perception::WorldTruth fromMessage(const world_state_t& m) {
  perception::WorldTruth w;
  w.utime = m.header.utime;
  w.field = m.field;
  w.scenario = m.scenario;
  w.robot_radius = m.robot_radius;
  // Bounded by the arrays too, so an unvalidated message cannot read past them.
  const std::size_t robots =
      std::min<std::size_t>(static_cast<std::size_t>(std::max(0, m.num_robots)),
                            std::min({m.robot_id.size(), m.robot_x.size(), m.robot_y.size(),
                                      m.robot_phi.size(), m.robot_vx.size(), m.robot_vy.size(),
                                      m.robot_omega.size(), m.robot_kidnaps.size()}));
  w.robots.resize(robots);
  for (std::size_t i = 0; i < robots; ++i) {
    auto& r = w.robots[i];
    r.id = m.robot_id[i];
    r.pose = {m.robot_x[i], m.robot_y[i], m.robot_phi[i]};
    r.velocity = {m.robot_vx[i], m.robot_vy[i]};
    r.omega = m.robot_omega[i];
    r.kidnaps = m.robot_kidnaps[i];
  }
  const std::size_t opponents =
      std::min<std::size_t>(static_cast<std::size_t>(std::max(0, m.num_opponents)),
                            std::min({m.opponent_x.size(), m.opponent_y.size(),
                                      m.opponent_phi.size(), m.opponent_radius.size()}));
  w.opponents.resize(opponents);
  for (std::size_t k = 0; k < opponents; ++k) {
    w.opponents[k].pose = {m.opponent_x[k], m.opponent_y[k], m.opponent_phi[k]};
    w.opponents[k].radius = m.opponent_radius[k];
  }
  w.ball.position = {m.ball_x, m.ball_y};
  w.ball.velocity = {m.ball_vx, m.ball_vy};
  w.ball.radius = m.ball_radius;
  return w;
}

void toMessage(const perception::WorldTruth& w, world_state_t& m) {
  m.header.utime = w.utime;
  m.field = w.field;
  m.scenario = w.scenario;
  m.robot_radius = static_cast<float>(w.robot_radius);
  const std::size_t n = w.robots.size();
  m.num_robots = static_cast<std::int32_t>(n);
  m.robot_id.resize(n);
  m.robot_x.resize(n);
  m.robot_y.resize(n);
  m.robot_phi.resize(n);
  m.robot_vx.resize(n);
  m.robot_vy.resize(n);
  m.robot_omega.resize(n);
  m.robot_kidnaps.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& r = w.robots[i];
    m.robot_id[i] = static_cast<std::int8_t>(r.id);
    m.robot_x[i] = r.pose.x;
    m.robot_y[i] = r.pose.y;
    m.robot_phi[i] = r.pose.phi;
    m.robot_vx[i] = r.velocity.x();
    m.robot_vy[i] = r.velocity.y();
    m.robot_omega[i] = r.omega;
    m.robot_kidnaps[i] = r.kidnaps;
  }
  const std::size_t k = w.opponents.size();
  m.num_opponents = static_cast<std::int32_t>(k);
  m.opponent_x.resize(k);
  m.opponent_y.resize(k);
  m.opponent_phi.resize(k);
  m.opponent_radius.resize(k);
  for (std::size_t j = 0; j < k; ++j) {
    m.opponent_x[j] = w.opponents[j].pose.x;
    m.opponent_y[j] = w.opponents[j].pose.y;
    m.opponent_phi[j] = w.opponents[j].pose.phi;
    m.opponent_radius[j] = static_cast<float>(w.opponents[j].radius);
  }
  m.ball_x = w.ball.position.x();
  m.ball_y = w.ball.position.y();
  m.ball_vx = w.ball.velocity.x();
  m.ball_vy = w.ball.velocity.y();
  m.ball_radius = static_cast<float>(w.ball.radius);
}

}  // namespace fieldline::msg
