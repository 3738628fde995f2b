#include "common/msg/team_state.hpp"

#include "common/msg/row_major.hpp"

#include <algorithm>

namespace fieldline::msg {

perception::TeamState fromMessage(const team_state_t& m) {
  perception::TeamState s;
  s.utime = m.header.utime;
  const std::size_t n = std::min<std::size_t>(
      {static_cast<std::size_t>(std::max(m.num_robots, 0)), perception::kTeamSize, m.present.size(),
       m.robot_x.size(), m.robot_y.size(), m.robot_phi.size(), m.robot_sigma_xy.size(),
       m.robot_age_us.size(), m.ball_valid.size(), m.ball_x.size(), m.ball_y.size(),
       m.ball_age_us.size(), m.clock_offset_us.size(), m.round_trip_us.size(),
       m.packets_received.size(), m.packets_rejected.size(), m.robot_twin_ambiguous.size()});
  for (std::size_t i = 0; i < n; ++i) {
    perception::TeammateState& r = s.robots[i];
    r.present = m.present[i];
    r.x = m.robot_x[i];
    r.y = m.robot_y[i];
    r.phi = m.robot_phi[i];
    r.sigma_xy = m.robot_sigma_xy[i];
    r.robot_age_us = m.robot_age_us[i];
    r.ball_valid = m.ball_valid[i];
    r.ball_x = m.ball_x[i];
    r.ball_y = m.ball_y[i];
    r.ball_age_us = m.ball_age_us[i];
    r.clock_offset_us = m.clock_offset_us[i];
    r.round_trip_us = m.round_trip_us[i];
    r.packets_received = m.packets_received[i];
    r.packets_rejected = m.packets_rejected[i];
    r.twin_ambiguous = m.robot_twin_ambiguous[i];
  }
  s.team_ball_valid = m.team_ball_valid;
  s.team_ball_x = m.team_ball_x;
  s.team_ball_y = m.team_ball_y;
  s.team_ball_vx = m.team_ball_vx;
  s.team_ball_vy = m.team_ball_vy;
  s.team_ball_covariance = fromRowMajor<2>(m.team_ball_covariance);
  return s;
}

void toMessage(const perception::TeamState& s, team_state_t& m) {
  m.header.utime = s.utime;
  constexpr int n = perception::kTeamSize;
  m.num_robots = n;
  m.present.resize(n);
  m.robot_x.resize(n);
  m.robot_y.resize(n);
  m.robot_phi.resize(n);
  m.robot_sigma_xy.resize(n);
  m.robot_age_us.resize(n);
  m.ball_valid.resize(n);
  m.ball_x.resize(n);
  m.ball_y.resize(n);
  m.ball_age_us.resize(n);
  m.clock_offset_us.resize(n);
  m.round_trip_us.resize(n);
  m.packets_received.resize(n);
  m.packets_rejected.resize(n);
  m.robot_twin_ambiguous.resize(n);
  for (int i = 0; i < n; ++i) {
    const perception::TeammateState& r = s.robots[static_cast<std::size_t>(i)];
    m.present[i] = r.present;
    m.robot_x[i] = r.x;
    m.robot_y[i] = r.y;
    m.robot_phi[i] = r.phi;
    m.robot_sigma_xy[i] = r.sigma_xy;
    m.robot_age_us[i] = r.robot_age_us;
    m.ball_valid[i] = r.ball_valid;
    m.ball_x[i] = r.ball_x;
    m.ball_y[i] = r.ball_y;
    m.ball_age_us[i] = r.ball_age_us;
    m.clock_offset_us[i] = r.clock_offset_us;
    m.round_trip_us[i] = r.round_trip_us;
    m.packets_received[i] = r.packets_received;
    m.packets_rejected[i] = r.packets_rejected;
    m.robot_twin_ambiguous[i] = r.twin_ambiguous;
  }
  m.team_ball_valid = s.team_ball_valid;
  m.team_ball_x = s.team_ball_x;
  m.team_ball_y = s.team_ball_y;
  m.team_ball_vx = s.team_ball_vx;
  m.team_ball_vy = s.team_ball_vy;
  toRowMajor<2>(s.team_ball_covariance, m.team_ball_covariance);
}

}  // namespace fieldline::msg
