#include "teamcomm/teamcomm_config.hpp"

#include <arpa/inet.h>

#include <cstdint>

#include "teamcomm/team_key.hpp"

namespace fieldline::teamcomm {
namespace {

Utime seconds(double s) {
  return static_cast<Utime>(s * 1e6);
}

// "file:line: team.transport.ttl: what", located as config errors are.
std::string located(const config::Node& n, const std::string& key, const std::string& what) {
  try {
    n.fail(key, what);
  } catch (const config::Error& e) {
    return e.what();
  }
}

}  // namespace

std::string checkTeamGroup(const std::string& group, std::vector<std::string>* warnings) {
  in_addr address{};
  if (group.empty()) return "must not be empty";
  if (::inet_pton(AF_INET, group.c_str(), &address) != 1) {
    return "'" + group + "' is not an IPv4 address (four numbers 0..255, e.g. 239.255.76.100)";
  }
  const std::uint32_t host = ntohl(address.s_addr);
  if ((host >> 28) != 0xe) {
    return "'" + group + "' is not a multicast group (224.0.0.0 to 239.255.255.255)";
  }
  if ((host >> 8) == 0xe00000) {
    return "'" + group +
           "' is in 224.0.0.0/24, the local network control block (224.0.0.1 is every host on "
           "the network, the others belong to routing protocols): use a group of 239.0.0.0/8, "
           "e.g. 239.255.76.100";
  }
  if ((host >> 24) != 0xef && warnings) {
    warnings->push_back("'" + group +
                        "' is not in 239.0.0.0/8 (administratively scoped): routers may forward "
                        "a globally scoped group beyond the team's network");
  }
  return "";
}

std::optional<std::uint16_t> udpmPort(const std::string& url) {
  const std::string scheme = "udpm://";
  if (!url.starts_with(scheme)) return std::nullopt;
  const auto end = url.find('?', scheme.size());
  const std::string address = url.substr(scheme.size(), end - scheme.size());
  const auto colon = address.rfind(':');
  if (colon == std::string::npos || colon + 1 == address.size()) return std::nullopt;
  int port = 0;
  for (const char ch : address.substr(colon + 1)) {
    if (ch < '0' || ch > '9' || port > 65535) return std::nullopt;
    port = port * 10 + (ch - '0');
  }
  if (port < 1 || port > 65535) return std::nullopt;
  return static_cast<std::uint16_t>(port);
}

namespace {

// team.picture: the team ball's fusion (PictureOptions).
void loadPictureOptions(const config::Node& p, PictureOptions& picture) {
  picture.present_timeout_us = seconds(p.getOr<double>("present_timeout_s", 0.5, 0.1, 10.0));
  picture.ball_timeout_us = seconds(p.getOr<double>("ball_timeout_s", 0.5, 0.1, 10.0));
  picture.gate_chi2 = p.getOr<double>("gate_chi2", 9.21, 1.0, 100.0);
  picture.superseded_after_us = seconds(p.getOr<double>("superseded_after_s", 0.09, 0.0, 1.0));
  picture.ball_radial_floor_per_m2 = p.getOr<double>("ball_radial_floor_per_m2", 0.0015, 0.0, 0.1);
  picture.carry_track = p.getOr<bool>("carry_track", true);
  picture.carry_speed_sigma_mps = p.getOr<double>("carry_speed_sigma_mps", 0.1, 0.0, 10.0);
  picture.ball_stamp_sigma_s = p.getOr<double>("ball_stamp_sigma_s", 0.01, 0.0, 1.0);
  p.rejectUnknownKeys();
}

}  // namespace

TeamcommConfig loadTeamcommConfig(const config::Node& root) {
  const config::Node t = root.child("team");
  TeamcommConfig c;
  c.node.team_id = static_cast<std::uint8_t>(t.get<int>("team_id", 0, 255));
  c.key_file = t.get<std::string>("key_file");
  c.node.send_rate_hz = t.get<double>("send_rate_hz", 10.0, 30.0);
  c.node.max_send_rate_hz = t.getOr<double>("max_send_rate_hz", 30.0, c.node.send_rate_hz, 30.0);
  c.node.publish_rate_hz = t.getOr<double>("publish_rate_hz", 10.0, 1.0, 50.0);
  c.node.poll_period_us = seconds(t.getOr<double>("poll_period_s", 0.002, 0.0005, 0.05));
  c.node.fresh_us = seconds(t.getOr<double>("fresh_s", 0.3, 0.02, 2.0));

  const config::Node u = t.child("transport");
  const std::string mode = u.getChoice("mode", {"multicast", "unicast"});
  c.udp.port = static_cast<std::uint16_t>(u.get<int>("port", 1, 65535));
  c.udp.interface = u.getOr<std::string>("interface", "");
  if (mode == "multicast") {
    c.udp.group = u.get<std::string>("group");
    std::vector<std::string> group_warnings;
    if (const std::string problem = checkTeamGroup(c.udp.group, &group_warnings);
        !problem.empty()) {
      u.fail("group", problem);
    }
    for (const std::string& w : group_warnings)
      c.warnings.push_back(located(u, "group", w));
    c.udp.ttl = u.getOr<int>("ttl", 1, 0, 255);
    if (c.udp.ttl > 1) {
      c.warnings.push_back(located(u, "ttl",
                                   "ttl " + std::to_string(c.udp.ttl) +
                                       " lets team packets cross " + std::to_string(c.udp.ttl - 1) +
                                       " router(s), e.g. into other fields' networks at a venue; "
                                       "1 keeps them on the team's network"));
    }
    c.udp.loopback = u.getOr<bool>("loopback", true);
    if (u.has("peers")) u.fail("peers", "peers are for mode: unicast");
  } else {
    c.udp.group.clear();
    c.udp.peers = u.getList<std::string>("peers");
    if (c.udp.peers.empty()) u.fail("peers", "unicast needs at least one peer host:port");
    for (const std::string& p : c.udp.peers) {
      try {
        parsePeer(p);
      } catch (const TransportError& e) {
        u.fail("peers", e.what());
      }
    }
  }
  u.rejectUnknownKeys();

  if (const auto g = t.childIf("gate")) {
    c.node.gate.rate_limit_hz = g->getOr<double>("rate_limit_hz", 40.0, 10.0, 1000.0);
    c.node.gate.burst = g->getOr<double>("burst", 10.0, 1.0, 1000.0);
    c.node.gate.max_age_us = seconds(g->getOr<double>("max_age_s", 1.0, 0.05, 60.0));
    c.node.gate.max_clock_difference_us =
        seconds(g->getOr<double>("max_clock_difference_s", 10.0, 0.1, 86400.0));
    g->rejectUnknownKeys();
  }
  if (const auto o = t.childIf("offset")) {
    c.node.offset.window_us = seconds(o->getOr<double>("window_s", 20.0, 1.0, 600.0));
    c.node.offset.max_round_trip_us =
        seconds(o->getOr<double>("max_round_trip_s", 0.5, 0.001, 5.0));
    c.node.offset_reset_after_stale_us =
        seconds(o->getOr<double>("reset_after_stale_s", 2.0, 0.5, 60.0));
    o->rejectUnknownKeys();
  }
  if (const auto p = t.childIf("picture")) loadPictureOptions(*p, c.node.picture);
  t.rejectUnknownKeys();
  root.rejectUnknownKeys();
  return c;
}

TeamKey loadConfiguredKey(const std::string& key_file) {
  const std::string path =
      key_file.starts_with('/') ? key_file : config::projectRoot() + "/" + key_file;
  return loadTeamKey(path);
}

}  // namespace fieldline::teamcomm
