#include "tools/recording/upgrade.hpp"

#include <fieldline_legacy/odometry_v1_t.hpp>
#include <fieldline_legacy/robot_state_v1_t.hpp>
#include <fieldline_legacy/team_state_v1_t.hpp>

#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"

namespace fieldline::recording {

namespace {

template <typename Old, typename New>
Upgrade makeUpgrade(std::string name, std::string_view channel, New (*convert)(const Old&)) {
  return Upgrade{std::move(name), std::string(channel), static_cast<std::int64_t>(Old::getHash()),
                 [convert](const void* data, int size, std::vector<std::uint8_t>& out) {
                   Old old{};
                   try {
                     if (old.decode(data, 0, size) != size) return false;
                   } catch (const std::exception&) {
                     return false;
                   }
                   const New now = convert(old);
                   out.resize(static_cast<std::size_t>(now.getEncodedSize()));
                   return now.encode(out.data(), 0, static_cast<int>(out.size())) ==
                          static_cast<int>(out.size());
                 }};
}

// a7e57fd (2026-12-03): ROBOT_STATE gained twin_ambiguous. An old pose was never flagged.
robot_state_t robotStateFromV1(const fieldline_legacy::robot_state_v1_t& o) {
  robot_state_t m{};
  m.header = o.header;
  m.x = o.x;
  m.y = o.y;
  m.phi = o.phi;
  m.vx = o.vx;
  m.vy = o.vy;
  m.omega = o.omega;
  std::copy(std::begin(o.covariance), std::end(o.covariance), std::begin(m.covariance));
  m.status = o.status;
  m.since_vision_us = o.since_vision_us;
  m.twin_ambiguous = 0;
  return m;
}

// f429e8e (2026-12-03): TEAM_STATE gained robot_twin_ambiguous per teammate (the team packet's
// version 2). Version 1 packets carried no flag: no teammate was flagged.
team_state_t teamStateFromV1(const fieldline_legacy::team_state_v1_t& o) {
  team_state_t m{};
  m.header = o.header;
  m.num_robots = o.num_robots;
  m.present = o.present;
  m.robot_x = o.robot_x;
  m.robot_y = o.robot_y;
  m.robot_phi = o.robot_phi;
  m.robot_sigma_xy = o.robot_sigma_xy;
  m.robot_age_us = o.robot_age_us;
  m.ball_valid = o.ball_valid;
  m.ball_x = o.ball_x;
  m.ball_y = o.ball_y;
  m.ball_age_us = o.ball_age_us;
  m.clock_offset_us = o.clock_offset_us;
  m.round_trip_us = o.round_trip_us;
  m.packets_received = o.packets_received;
  m.packets_rejected = o.packets_rejected;
  m.robot_twin_ambiguous.assign(static_cast<std::size_t>(std::max(0, o.num_robots)), 0);
  m.team_ball_valid = o.team_ball_valid;
  m.team_ball_x = o.team_ball_x;
  m.team_ball_y = o.team_ball_y;
  m.team_ball_vx = o.team_ball_vx;
  m.team_ball_vy = o.team_ball_vy;
  std::copy(std::begin(o.team_ball_covariance), std::end(o.team_ball_covariance),
            std::begin(m.team_ball_covariance));
  return m;
}

// Issue 29 (2026-12-06): ODOMETRY gained wheel_count; ticks and wheel_current are sized by it (a
// robot has three or four wheels). Every older controller had three.
odometry_t odometryFromV1(const fieldline_legacy::odometry_v1_t& o) {
  odometry_t m{};
  m.header = o.header;
  m.wheel_count = 3;
  m.ticks.assign(std::begin(o.ticks), std::end(o.ticks));
  m.controller_utime = o.controller_utime;
  m.dx = o.dx;
  m.dy = o.dy;
  m.dphi = o.dphi;
  m.vx = o.vx;
  m.vy = o.vy;
  m.omega = o.omega;
  m.status = o.status;
  m.wheel_current.assign(std::begin(o.wheel_current), std::end(o.wheel_current));
  m.gyro_dphi = o.gyro_dphi;
  return m;
}

}  // namespace

const std::vector<Upgrade>& knownUpgrades() {
  static const std::vector<Upgrade> upgrades{
      makeUpgrade("robot_state_t v1", bus::channels::kRobotState.name, &robotStateFromV1),
      makeUpgrade("team_state_t v1", bus::channels::kTeamState.name, &teamStateFromV1),
      makeUpgrade("odometry_t v1", bus::channels::kOdometry.name, &odometryFromV1),
  };
  return upgrades;
}

std::optional<std::string> upgradeEvent(bus::LogEvent& event) {
  std::string applied;
  std::vector<std::uint8_t> out;
  // A chain of changes is a chain of upgrades; each step changes the fingerprint, so this ends.
  for (std::size_t step = 0; step <= knownUpgrades().size(); ++step) {
    const auto fingerprint =
        bus::detail::fingerprintOf(event.data.data(), static_cast<int>(event.data.size()));
    if (!fingerprint) break;
    const Upgrade* match = nullptr;
    for (const Upgrade& u : knownUpgrades()) {
      if (u.from_fingerprint == *fingerprint && u.channel == event.channel) match = &u;
    }
    if (!match || !match->convert(event.data.data(), static_cast<int>(event.data.size()), out))
      break;
    event.data.swap(out);
    applied += (applied.empty() ? "" : " + ") + match->name;
  }
  if (applied.empty()) return std::nullopt;
  return applied;
}

void installLogUpgrades() {
  bus::setLogUpgrade(&upgradeEvent);
}

}  // namespace fieldline::recording
