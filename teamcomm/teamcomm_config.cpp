#include "teamcomm/teamcomm_config.hpp"

#include "teamcomm/team_key.hpp"

namespace fieldline::teamcomm {
namespace {

Utime seconds(double s) {
  return static_cast<Utime>(s * 1e6);
}

}  // namespace

TeamcommConfig loadTeamcommConfig(const config::Node& root) {
  const config::Node t = root.child("team");
  TeamcommConfig c;
  c.node.team_id = static_cast<std::uint8_t>(t.get<int>("team_id", 0, 255));
  c.key_file = t.get<std::string>("key_file");
  c.node.send_rate_hz = t.get<double>("send_rate_hz", 10.0, 30.0);
  c.node.publish_rate_hz = t.getOr<double>("publish_rate_hz", 10.0, 1.0, 50.0);
  c.node.poll_period_us = seconds(t.getOr<double>("poll_period_s", 0.002, 0.0005, 0.05));
  c.node.fresh_us = seconds(t.getOr<double>("fresh_s", 0.3, 0.02, 2.0));

  const config::Node u = t.child("transport");
  const std::string mode = u.getChoice("mode", {"multicast", "unicast"});
  c.udp.port = static_cast<std::uint16_t>(u.get<int>("port", 1, 65535));
  c.udp.interface = u.getOr<std::string>("interface", "");
  if (mode == "multicast") {
    c.udp.group = u.get<std::string>("group");
    c.udp.ttl = u.getOr<int>("ttl", 1, 0, 255);
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
    o->rejectUnknownKeys();
  }
  if (const auto p = t.childIf("picture")) {
    c.node.picture.present_timeout_us =
        seconds(p->getOr<double>("present_timeout_s", 0.5, 0.1, 10.0));
    c.node.picture.ball_timeout_us = seconds(p->getOr<double>("ball_timeout_s", 1.0, 0.1, 10.0));
    c.node.picture.gate_chi2 = p->getOr<double>("gate_chi2", 9.21, 1.0, 100.0);
    p->rejectUnknownKeys();
  }
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
